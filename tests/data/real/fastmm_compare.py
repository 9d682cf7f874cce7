"""Runs fastmm (pip install fastmm) on exactly the network and points that
Waymark matches, and scores both complete paths against the same truth.

Usage: python3 fastmm_compare.py DUMP.json TRUTH.csv|- RADIUS_M GPS_ERROR_M [REPEATS]
  DUMP.json: from `cargo run --release --example match_dump -- MAP TRACK DUMP.json`
  TRUTH.csv: road_id[,length_m] (as `waymark match --truth`), or - for none.
  RADIUS_M, GPS_ERROR_M: a number, or `auto` for each track's own search
  radius and sigma-hat as `waymark match` takes them from the track (the
  dump's "params").
Prints one JSON line: precision/recall by length (and by count), matched
share of points, points per second for matching alone and for the whole
run (network, UBODT and matching), as Waymark's `match --json` reports them.
"""
import csv, json, math, os, sys, tempfile, time

t_start = time.perf_counter()
import fastmm  # noqa: E402

dump = json.load(open(sys.argv[1]))
truth_path = sys.argv[2]


def setting(arg, key):
    """A fixed number, or the track's own (`auto`: the dump's params)."""
    if arg == "auto":
        return lambda tid: dump["params"][tid][key]
    return lambda tid, v=float(arg): v


radius_of = setting(sys.argv[3], "radius_m")
gps_error_of = setting(sys.argv[4], "sigma_hat_m")
# Matching alone is timed over REPEATS runs of every track (the score is the
# first run's); the whole run's rate counts one run.
repeats = int(sys.argv[5]) if len(sys.argv) > 5 else 1

net = fastmm.Network()
road_of = {}
for s in dump["sections"]:
    pts = [tuple(p) for p in s["enu"]]
    if s["oneway"] in ("both", "forward"):
        e = 2 * s["id"]
        net.add_edge(e, source=s["start"], target=s["end"], geom=pts)
        road_of[e] = s["road"]
    if s["oneway"] in ("both", "backward"):
        e = 2 * s["id"] + 1
        net.add_edge(e, source=s["end"], target=s["start"], geom=pts[::-1])
        road_of[e] = s["road"]
net.finalize()
cache = tempfile.mkdtemp()
# UBODT bound: 3 km (every transition of these traces is shorter).
fmm = fastmm.FastMapMatch(net, fastmm.TransitionMode.SHORTEST,
                          max_distance_between_candidates=3000.0, cache_dir=cache)
lengths, points, matched, t_match = {}, 0, 0, 0.0
for tid, fixes in dump["tracks"].items():
    traj = fastmm.Trajectory.from_xy_tuples([(x, y) for x, y, _ in fixes])
    radius, gps_error = radius_of(tid), gps_error_of(tid)
    t0 = time.perf_counter()
    res = fmm.match(traj, max_candidates=8, candidate_search_radius=radius,
                    gps_error=gps_error)
    t_first = time.perf_counter() - t0
    t_all_so_far = time.perf_counter()
    for _ in range(repeats - 1):
        fmm.match(traj, max_candidates=8, candidate_search_radius=radius,
                  gps_error=gps_error)
    t_match += t_first + time.perf_counter() - t_all_so_far
    t_extra = time.perf_counter() - t_all_so_far
    t_start += t_extra  # the whole run counts one match of each track
    points += len(fixes)
    for sub in res.subtrajectories:
        if sub.error_code != fastmm.MatchErrorCode.SUCCESS:
            continue
        matched += sub.end_index - sub.start_index + 1
        for seg in sub.segments:
            for e in seg.edges:
                d = sum(p.d for p in e.points)
                r = road_of[e.edge_id]
                lengths[r] = lengths.get(r, 0.0) + d
t_all = time.perf_counter() - t_start
out = {"points": points, "matched_share": matched / points,
       "match_points_per_s": points * repeats / t_match, "whole_points_per_s": points / t_all,
       "path_length_m": sum(lengths.values())}
if truth_path != "-":
    road_len = {}
    for s in dump["sections"]:
        p = s["enu"]
        road_len[s["road"]] = road_len.get(s["road"], 0.0) + sum(
            math.dist(p[i], p[i + 1]) for i in range(len(p) - 1))
    truth = {}
    for row in csv.DictReader(open(truth_path)):
        L = float(row["length_m"]) if row.get("length_m") else road_len[row["road_id"]]
        truth[row["road_id"]] = truth.get(row["road_id"], 0.0) + L
    m = sum(lengths.values())
    on = sum(v for k, v in lengths.items() if k in truth)
    cov = sum(min(lengths.get(k, 0.0), v) for k, v in truth.items())
    correct = sum(1 for k in lengths if k in truth)
    out.update(precision_length=on / m if m else 0.0, recall_length=cov / sum(truth.values()),
               precision_count=correct / len(lengths) if lengths else 0.0,
               recall_count=correct / len(truth))
print(json.dumps(out))
