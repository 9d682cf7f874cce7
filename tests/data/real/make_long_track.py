#!/usr/bin/env python3
"""A long synthetic track on FMM's example network (fmm-network.geojson), for
measuring `waymark match`'s memory on huge input (BENCHMARKS.md, "Streaming
match"). Not committed: generate it.

Usage: python3 tests/data/real/make_long_track.py OUT.csv MEGABYTES [TRUTH.csv]

A seeded random walk over the network's directed roads (never straight back
along the road it came by when another way out exists), a fix every 5 m at
5 m/s with 3 m (1 sigma per axis) noise, written as t_s,lat,lon until the
file reaches MEGABYTES. TRUTH.csv (optional): the roads walked, as
`waymark match --truth` reads them (road_id,length_m: each road's length in
the map's frame times the number of walks along it; every edge walked is
walked to its end).
"""
import json, math, os, random, sys

out, mb = sys.argv[1], float(sys.argv[2])
net = json.load(open(os.path.join(os.path.dirname(__file__), "fmm-network.geojson")))
edges = [f["geometry"]["coordinates"] for f in net["features"]]
ids = [f["id"] for f in net["features"]]
walked = {}
lat0 = edges[0][0][1]
mx = 111_412.0 * math.cos(math.radians(lat0))  # m per degree of longitude
my = 111_195.0                                   # m per degree of latitude
starts = {}
for i, e in enumerate(edges):
    starts.setdefault(tuple(e[0]), []).append(i)
rng = random.Random(1)
limit = int(mb * 1e6)
t, cur, prev = 0, 0, None
with open(out, "w") as f:
    f.write("t_s,lat,lon\n")
    size = 12
    carry = 0.0  # metres already walked into the current edge
    while size < limit:
        e = edges[cur]
        length = 0.0
        for (x0, y0), (x1, y1) in zip(e, e[1:]):
            seg = math.hypot((x1 - x0) * mx, (y1 - y0) * my)
            length += seg
            s = carry
            while s < seg:
                u = s / seg
                lon = x0 + u * (x1 - x0) + rng.gauss(0, 3.0) / mx
                lat = y0 + u * (y1 - y0) + rng.gauss(0, 3.0) / my
                line = f"{t},{lat:.7f},{lon:.7f}\n"
                f.write(line)
                size += len(line)
                t += 1
                s += 5.0
            carry = s - seg
        walked[ids[cur]] = walked.get(ids[cur], 0.0) + length
        nxt = starts.get(tuple(e[-1]), [])
        back = [i for i in nxt if edges[i][-1] == e[0]]
        choices = [i for i in nxt if i not in back] or nxt
        prev, cur = cur, rng.choice(choices)
if len(sys.argv) > 3:
    with open(sys.argv[3], "w") as f:
        f.write("road_id,length_m\n")
        for road, length in sorted(walked.items(), key=lambda kv: int(kv[0])):
            f.write(f"{road},{length:.2f}\n")
