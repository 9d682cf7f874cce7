"""Candidates per point and candidate pairs per point (the transitions a
matcher evaluates) for a search radius and a candidate cap, on exactly the
network and points Waymark matches. Both Waymark and fastmm take one
candidate per directed road piece within the radius, capped at k, and
evaluate every pair of consecutive points' candidates.

Usage: python3 candidate_pairs.py DUMP.json RADIUS_M[,RADIUS_M...] K
  DUMP.json: from `cargo run --release --example match_dump -- MAP TRACK DUMP.json`
  RADIUS_M: one radius for every track, or one per track (Waymark's are in
  `waymark match --json`'s radius_m).
Prints one JSON line: points, candidates per point, pairs per point.
"""
import json, math, sys


def seg_dist(p, a, b):
    dx, dy = b[0] - a[0], b[1] - a[1]
    ll = dx * dx + dy * dy
    t = 0.0 if ll == 0 else max(0.0, min(1.0, ((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / ll))
    return math.dist(p, (a[0] + t * dx, a[1] + t * dy))


dump = json.load(open(sys.argv[1]))
radii = [float(r) for r in sys.argv[2].split(",")]
cap = int(sys.argv[3])
tracks = list(dump["tracks"].values())
if len(radii) == 1:
    radii = radii * len(tracks)
points = cands = pairs = 0
for fixes, r in zip(tracks, radii):
    prev = None
    for x, y, *_ in fixes:
        n = 0
        for s in dump["sections"]:
            e = s["enu"]
            if min(seg_dist((x, y), e[i], e[i + 1]) for i in range(len(e) - 1)) <= r:
                n += 1 if s["oneway"] in ("forward", "backward") else 2
        n = min(n, cap)
        points += 1
        cands += n
        if prev is not None:
            pairs += prev * n
        prev = n
print(json.dumps({"points": points, "candidates_per_point": cands / points,
                  "pairs_per_point": pairs / points}))
