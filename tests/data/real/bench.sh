#!/usr/bin/env bash
# The "Matching" table of BENCHMARKS.md: Waymark and fastmm on the real
# traces. Usage: tests/data/real/bench.sh [EXTRA_MAP EXTRA_TRACK]...
# Needs: cargo build --release --bin waymark --example match_bench --example match_dump;
# pip install fastmm. Prints one line per case and matcher.
set -euo pipefail
D=$(cd "$(dirname "$0")" && pwd)
T=${CARGO_TARGET_DIR:-target}/release
W=$T/waymark; E=$T/examples
tmp=$(mktemp -d)
case_run() {  # name map track truth|- fastmm-radius fastmm-gps-error
  local name=$1 map=$2 track=$3 truth=$4 r=$5 g=$6
  local targs=(); [ "$truth" != - ] && targs=(--truth "$truth")
  local t0 t1
  t0=$(date +%s.%N)
  for _ in 1 2 3 4 5; do "$W" match --map "$map" --track "$track" --out "$tmp/m.csv" \
      --path "$tmp/p.csv" "${targs[@]}" --json > "$tmp/w.json" 2>/dev/null; done
  t1=$(date +%s.%N)
  local alone; alone=$("$E/match_bench" "$map" "$track" 2000)
  python3 - "$tmp/w.json" "$t0" "$t1" "$alone" "$name" <<'PY'
import json, sys
w = json.load(open(sys.argv[1])); a = json.loads(sys.argv[4])
s = w.get("score") or {}
whole = w["points"] * 5 / (float(sys.argv[3]) - float(sys.argv[2]))
print(f"{sys.argv[5]} | waymark | {s.get('precision_length', float('nan')):.3f} | {s.get('recall_length', float('nan')):.3f} | "
      f"{w['matched_share']:.2f} | {w['path_length_m']:.0f} | {a['match_points_per_s']:.0f} (warm cache {a['warm_match_points_per_s']:.0f}) | {whole:.0f}")
PY
  "$E/match_dump" "$map" "$track" "$tmp/dump.json"
  python3 "$D/fastmm_compare.py" "$tmp/dump.json" "$truth" "$r" "$g" 2000 2>/dev/null | grep '^{' | python3 -c "
import json, sys
f = json.load(sys.stdin)
print(f\"$name | fastmm (r $r m, σ $g m) | {f.get('precision_length', float('nan')):.3f} | {f.get('recall_length', float('nan')):.3f} | {f['matched_share']:.2f} | {f['path_length_m']:.0f} | {f['match_points_per_s']:.0f} | {f['whole_points_per_s']:.0f}\")"
}
echo "case | matcher | precision | recall | matched | path m | pts/s matching | pts/s whole"
case_run "FMM example (3 trips)" "$D/fmm-network.geojson" "$D/fmm-trips.geojson" "$D/fmm-truth.csv" 100 20
case_run "FMM example (3 trips)" "$D/fmm-network.geojson" "$D/fmm-trips.geojson" "$D/fmm-truth.csv" 80 100
case_run "GraphHopper issue 70" "$D/issue-70.osm" "$D/issue-70.gpx" "$D/issue-70-truth.csv" 100 20
case_run "GraphHopper issue 13" "$D/issue-13.osm" "$D/issue-13.gpx" - 100 20
while [ $# -ge 2 ]; do case_run "$(basename "$2")" "$1" "$2" - 100 20; shift 2; done
rm -rf "$tmp"
