#!/usr/bin/env bash
# usage: scripts/plancmp.sh OLD_WAYMARK NEW_WAYMARK [RUNS]   (from a checkout's root)
# Plans every bundled scenario with a [planner] section (14) with both
# binaries (--runs RUNS, default 10, --seed 7) and compares the tag layouts
# (tags.csv, cmp) and the validations (plan.json's "validation" object, every
# number in both; a field only one build writes is left out): prints "identical" or "DIFFERENT" per scenario and a count; exit 1
# if any differs. For changes to code the planner shares (the grid, routing).
set -uo pipefail
old=$1; new=$2; runs=${3:-10}
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
same=0; total=0
for f in $(grep -l '^\[planner\]' scenarios/*.toml); do
  n=$(basename "$f" .toml)
  for who in old new; do
    bin=$old; [ $who = new ] && bin=$new
    "$bin" plan "$f" --runs "$runs" --seed 7 --out "$tmp/$who-$n" -q > /dev/null 2> "$tmp/$who-$n.err"
    echo "exit $?" >> "$tmp/$who-$n.err"
  done
  total=$((total + 1))
  if cmp -s "$tmp/old-$n/tags.csv" "$tmp/new-$n/tags.csv" && cmp -s "$tmp/old-$n.err" "$tmp/new-$n.err" \
     && python3 - "$tmp/old-$n/plan.json" "$tmp/new-$n/plan.json" <<'PY'
import json, sys
a, b = (json.load(open(p)).get("validation") for p in sys.argv[1:3])
if isinstance(a, dict) and isinstance(b, dict):
    # Fields one build adds are not a difference in the validation itself.
    a, b = ({k: v for k, v in x.items() if k in a and k in b} for x in (a, b))
sys.exit(0 if a == b and a is not None else 1)
PY
  then same=$((same + 1)); echo "$n identical"; else echo "$n DIFFERENT"; fi
done
echo "$same of $total identical"
[ $same = $total ]
