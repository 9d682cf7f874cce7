"""Builds the scaled FMM example (tests/data/real/fmm-*) from cyang-kth/fmm's
example/data (edges.shp, trips.csv, mr.txt; Apache-2.0).

FMM's example is drawn in degrees on a 4 x 4 grid of 1-degree cells. It is
scaled here to a small town: 1 unit = 0.0018 degree of latitude and 0.0036
degree of longitude (about 200 m each way at 60 N), placed at 60 N 24 E.
The GPS points then lie up to ~65 m from their roads and ~100-250 m apart,
and FMM's own committed result (mr.txt, its complete path `cpath`) is the
ground truth. Every edge of FMM's network is directed (a two-way street is
two edges), so each becomes a one-way road with FMM's edge id.

Usage: python3 make_fmm_example.py FMM_EXAMPLE_DATA_DIR OUT_DIR
"""
import csv, json, math, sys
import shapefile  # pip install pyshp

src, out = sys.argv[1], sys.argv[2]
LAT0, LON0, SY, SX = 60.0, 24.0, 0.0018, 0.0036


def ll(x, y):
    return [round(LON0 + x * SX, 8), round(LAT0 + y * SY, 8)]


def dist(a, b):
    # Haversine (m) between [lon, lat] points.
    R = 6371008.8
    p1, p2 = math.radians(a[1]), math.radians(b[1])
    dp, dl = p2 - p1, math.radians(b[0] - a[0])
    h = math.sin(dp / 2) ** 2 + math.cos(p1) * math.cos(p2) * math.sin(dl / 2) ** 2
    return 2 * R * math.asin(math.sqrt(h))


r = shapefile.Reader(f"{src}/edges.shp")
fields = [f[0] for f in r.fields[1:]]
features, edges = [], {}
for sr in r.shapeRecords():
    rec = dict(zip(fields, sr.record))
    coords = [ll(x, y) for x, y in sr.shape.points]
    edges[int(rec["id"])] = sr.shape.points
    features.append({"type": "Feature", "id": str(rec["id"]),
                     "properties": {"highway": "residential", "oneway": "yes"},
                     "geometry": {"type": "LineString", "coordinates": coords}})
json.dump({"type": "FeatureCollection", "features": features},
          open(f"{out}/fmm-network.geojson", "w"))

# Tracks: trips.csv (id;WKT LINESTRING), one feature per trip, no times.
tracks = []
for row in csv.DictReader(open(f"{src}/trips.csv"), delimiter=";"):
    wkt = row["geom"][row["geom"].index("(") + 1:-1]
    pts = [ll(*map(float, p.split())) for p in wkt.split(",")]
    tracks.append({"type": "Feature", "properties": {"track_id": row["id"]},
                   "geometry": {"type": "LineString", "coordinates": pts}})
json.dump({"type": "FeatureCollection", "features": tracks},
          open(f"{out}/fmm-trips.geojson", "w"), indent=0)

# Truth: FMM's cpath with the length driven on each edge (its mgeom cut
# along the path: partial first and last edges).
with open(f"{out}/fmm-truth.csv", "w") as f:
    f.write("track_id,road_id,length_m\n")
    for row in csv.DictReader(open(f"{src}/mr.txt"), delimiter=";"):
        cpath = [int(e) for e in row["cpath"].split(",")]
        wkt = row["mgeom"][row["mgeom"].index("(") + 1:-1]
        m = [tuple(map(float, p.split())) for p in wkt.split(",")]
        # Vertices of mgeom: first point, then each edge's end, last point.
        for k, e in enumerate(cpath):
            a, b = m[k], m[k + 1]
            f.write(f"{row['id']},{e},{dist(ll(*a), ll(*b)):.2f}\n")
