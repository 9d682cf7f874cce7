#!/usr/bin/env bash
# usage: scripts/matchcmp.sh OLD_WAYMARK NEW_WAYMARK   (from a checkout's root)
# Runs `waymark match` of both binaries on the real cases of tests/data/real
# (FMM's example with the radius from the track, `--radius-m 100` and `80`;
# GraphHopper issues 70, 13 and 127) and on the 11,139-point long track of
# make_long_track.py (0.3 MB), with both models (drift, independent): 14
# cases. Prints "identical" or "DIFFERENT" per case, comparing MATCHED.csv
# and the complete path (--path) with cmp, and a count at the end. Exit 1 if
# any differs.
set -uo pipefail
old=$1; new=$2
D=tests/data/real
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
python3 $D/make_long_track.py "$tmp/long.csv" 0.3 > /dev/null
cases=(
  "fmm-sigma|$D/fmm-network.geojson|$D/fmm-trips.geojson|"
  "fmm-r100|$D/fmm-network.geojson|$D/fmm-trips.geojson|--radius-m 100"
  "fmm-r80|$D/fmm-network.geojson|$D/fmm-trips.geojson|--radius-m 80"
  "issue-70|$D/issue-70.osm|$D/issue-70.gpx|"
  "issue-13|$D/issue-13.osm|$D/issue-13.gpx|"
  "issue-127|$D/issue-13.osm|$D/issue-127.gpx|"
  "long|$D/fmm-network.geojson|$tmp/long.csv|"
)
same=0; total=0
for model in drift independent; do
  for c in "${cases[@]}"; do
    IFS='|' read -r name map track extra <<< "$c"
    for who in old new; do
      bin=$old; [ $who = new ] && bin=$new
      # shellcheck disable=SC2086
      "$bin" match --map "$map" --track "$track" --model $model $extra \
        --out "$tmp/$who.csv" --path "$tmp/$who-path.csv" -q > /dev/null 2> "$tmp/$who.err"
      echo "exit $?" >> "$tmp/$who.err"
    done
    total=$((total + 1))
    if cmp -s "$tmp/old.csv" "$tmp/new.csv" && cmp -s "$tmp/old-path.csv" "$tmp/new-path.csv" \
       && cmp -s "$tmp/old.err" "$tmp/new.err"; then
      same=$((same + 1)); echo "$model $name identical"
    else
      echo "$model $name DIFFERENT"
    fi
  done
done
echo "$same of $total identical"
[ $same = $total ]
