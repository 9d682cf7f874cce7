#!/usr/bin/env bash
# usage: scripts/matchinstr.sh MATCH_BENCH [drift|independent] [fresh]   (from a checkout's root)
# Instructions per point of matching alone (callgrind: load-independent),
# from target/release/examples/match_bench, on FMM's example (the radius
# from the track, `--radius-m 100`, `--radius-m 80`) and GraphHopper issues
# 70 and 13. Warm (the route cache kept between repeats, the like-for-like
# of fastmm's precomputed table) = (I(101 warm repeats) - I(1)) / 100 /
# points; cold (an empty cache per repeat, as one `waymark match` run) =
# (I(100 cold + 100 warm) - I(1 warm) - 99 warm) / 100 / points. Needs
# valgrind. Prints one line per case: name, warm, cold. With `long` as a
# third or fourth argument, also the 11,139-point track of
# tests/data/real/make_long_track.py on FMM's network, with 11 repeats
# instead of 101 (and 10 cold) to keep callgrind's time reasonable.
set -euo pipefail
mb=$1; model=${2:-drift}; fresh=${3:-}; long=
for a in "${@:3}"; do [ "$a" = long ] && long=1; done
[ "$fresh" = long ] && fresh=
flags=(); [ "$model" = independent ] && flags+=(independent); [ -n "$fresh" ] && flags+=(fresh)
D=tests/data/real
instr() {  # args for match_bench -> total instructions
  valgrind --tool=callgrind --callgrind-out-file=/dev/null "$mb" "$@" 2>&1 >/dev/null \
    | sed -n 's/.*Collected : \([0-9]*\).*/\1/p'
}
run() {  # name map track radius|- [repeats]
  local name=$1 map=$2 track=$3 r=$4 n=${5:-100}
  local pts; pts=$("$mb" "$map" "$track" 1 "$r" warm "${flags[@]}" | python3 -c 'import json,sys; print(json.load(sys.stdin)["points"])')
  local w1 w101 c100
  w1=$(instr "$map" "$track" 1 "$r" warm "${flags[@]}")
  w101=$(instr "$map" "$track" $((n + 1)) "$r" warm "${flags[@]}")
  c100=$(instr "$map" "$track" "$n" "$r" "${flags[@]}")
  python3 - "$name" "$pts" "$w1" "$w101" "$c100" "$n" <<'PY'
import sys
name, pts, w1, w101, c100, n = sys.argv[1], *map(int, sys.argv[2:])
warm = (w101 - w1) / n / pts
cold = (c100 - w1 - (n - 1) * warm * pts) / n / pts
print(f"{name}: warm {warm:,.0f}, cold {cold:,.0f} instructions per point")
PY
}
echo "model $model ${fresh:+(fresh outputs)}"
run "FMM example, radius from the track" $D/fmm-network.geojson $D/fmm-trips.geojson -
run "FMM example, --radius-m 100" $D/fmm-network.geojson $D/fmm-trips.geojson 100
run "FMM example, --radius-m 80" $D/fmm-network.geojson $D/fmm-trips.geojson 80
run "GraphHopper issue 70" $D/issue-70.osm $D/issue-70.gpx -
run "GraphHopper issue 13" $D/issue-13.osm $D/issue-13.gpx -
if [ -n "$long" ]; then
  tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
  python3 $D/make_long_track.py "$tmp/long.csv" 0.3 > /dev/null
  run "Long track (11,139 points, FMM network)" $D/fmm-network.geojson "$tmp/long.csv" - 10
fi
