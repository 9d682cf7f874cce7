#!/usr/bin/env bash
# usage: scripts/simcmp.sh OLD_WAYMARK NEW_WAYMARK [RUNS]   (from a checkout's root)
# Simulates every bundled scenario with both binaries (--runs RUNS, default
# 2, --seed 3) and compares summary.json and errors.csv byte for byte, and
# the messages and exit codes (a scenario `simulate` refuses, such as a
# network plan without a [[route]], must be refused alike): prints
# "identical" or "DIFFERENT" per scenario and a count; exit 1 if any
# differs. For changes to the simulation meant to leave existing scenarios'
# results alone (new optional fields, refactoring). With ERRORS_COLS set
# (e.g. ERRORS_COLS=1-9), errors.csv is compared on those columns only
# (`cut -d, -f`), for a NEW that adds columns.
set -uo pipefail
old=$1; new=$2; runs=${3:-2}
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
same=0; total=0
for f in scenarios/*.toml; do
  n=$(basename "$f" .toml)
  for who in old new; do
    bin=$old; [ $who = new ] && bin=$new
    "$bin" simulate "$f" --runs "$runs" --seed 3 --out "$tmp/$who-$n" -q > /dev/null 2> "$tmp/$who-$n.err"
    echo "exit $?" >> "$tmp/$who-$n.err"
  done
  total=$((total + 1))
  ok=1
  cmp -s "$tmp/old-$n.err" "$tmp/new-$n.err" || ok=0
  for file in summary.json errors.csv; do
    a="$tmp/old-$n/$file"; b="$tmp/new-$n/$file"
    if [ "$file" = errors.csv ] && [ -n "${ERRORS_COLS:-}" ] && [ -e "$a" ] && [ -e "$b" ]; then
      cut -d, -f"$ERRORS_COLS" "$a" > "$a.cut"; cut -d, -f"$ERRORS_COLS" "$b" > "$b.cut"
      a="$a.cut"; b="$b.cut"
    fi
    if [ -e "$a" ] || [ -e "$b" ]; then cmp -s "$a" "$b" || ok=0; fi
  done
  if [ $ok = 1 ]; then same=$((same + 1)); echo "$n identical"; else echo "$n DIFFERENT"; fi
done
echo "$same of $total identical"
[ $same = $total ]
