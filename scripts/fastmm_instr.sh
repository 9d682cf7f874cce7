#!/usr/bin/env bash
# usage: scripts/fastmm_instr.sh MATCH_DUMP MAP TRACK TRUTH|- RADIUS_M|auto GPS_ERROR_M|auto
# (from a checkout's root; pip install fastmm; valgrind)
# fastmm's instructions per point of matching alone, the like-for-like of
# scripts/matchinstr.sh's warm figure: callgrind over the whole Python
# process (--trace-children=yes), tests/data/real/fastmm_compare.py with 201
# repeats minus one with 1 (network, UBODT and interpreter start cancel),
# / 200 / points. `auto`: the track's own radius / sigma-hat as Waymark takes
# them (fastmm_compare.py's doc). REPEATS=N in the environment: N + 1
# repeats minus 1 instead of 201 minus 1 (e.g. 10 for a long track).
set -euo pipefail
md=$1; map=$2; track=$3; truth=$4; r=$5; g=$6
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
"$md" "$map" "$track" "$tmp/dump.json"
pts=$(python3 -c 'import json,sys; d=json.load(open(sys.argv[1])); print(sum(len(v) for v in d["tracks"].values()))' "$tmp/dump.json")
instr() {
  valgrind --tool=callgrind --trace-children=yes --callgrind-out-file="$tmp/cg.%p" \
    python3 tests/data/real/fastmm_compare.py "$tmp/dump.json" "$truth" "$r" "$g" "$1" > /dev/null 2>&1
  local s=0
  for f in "$tmp"/cg.*; do
    s=$((s + $(sed -n 's/^summary: \([0-9]*\).*/\1/p;s/^totals: \([0-9]*\).*/\1/p' "$f" | head -1)))
  done
  rm -f "$tmp"/cg.*
  echo $s
}
n=${REPEATS:-200}
i1=$(instr 1); i201=$(instr $((n + 1)))
python3 -c "import sys; a,b,p,n=map(int,sys.argv[1:5]); print(f'fastmm r {sys.argv[5]} σ {sys.argv[6]}: {(b-a)/n/p:,.0f} instructions per point ({p} points)')" "$i1" "$i201" "$pts" "$n" "$r" "$g"
