#!/usr/bin/env python3
"""compare-outputs.py A B: compares two folders of Waymark outputs (as written
by scripts/run-bundled.sh) number by number: for every JSON and CSV file, the
largest relative difference and how many values differ. Timings and input
paths are ignored; KML/GPX/GeoJSON/HTML/PNG are not compared."""
import sys, os, json, csv, math
A, B = sys.argv[1], sys.argv[2]
IGN = ('time_s', 'elapsed', 'plan_time', '_ms', 'out', 'waymark_version')
worst = []
def num(x):
    try: return float(x)
    except: return None
def k_is_path(path):
    return path.endswith('_path')

def cmpval(a, b, path, acc):
    if isinstance(a, dict) and isinstance(b, dict):
        for k in set(a) | set(b):
            if any(s in k for s in IGN): continue
            if k not in a or k not in b: acc.append((math.inf, path + '/' + k + ' missing')); continue
            cmpval(a[k], b[k], path + '/' + k, acc)
    elif isinstance(a, list) and isinstance(b, list):
        if len(a) != len(b): acc.append((math.inf, path + f' len {len(a)} vs {len(b)}')); return
        for i, (x, y) in enumerate(zip(a, b)): cmpval(x, y, f'{path}[{i}]', acc)
    elif isinstance(a, (int, float)) and isinstance(b, (int, float)) and not isinstance(a, bool):
        d = abs(a - b) / max(abs(a), abs(b), 1e-9)
        if d > 0: acc.append((d, path + f' {a} vs {b}'))
    elif a != b:
        if k_is_path(path): return
        acc.append((math.inf, path + f' {str(a)[:60]!r} vs {str(b)[:60]!r}'))
for dp, _, fs in os.walk(A):
    for f in fs:
        pa = os.path.join(dp, f); rel = os.path.relpath(pa, A); pb = os.path.join(B, rel)
        if not os.path.exists(pb): print('MISSING in B:', rel); continue
        acc = []
        if f.endswith('.json'):
            try: cmpval(json.load(open(pa)), json.load(open(pb)), '', acc)
            except Exception as e: acc.append((math.inf, str(e)))
        elif f.endswith('.csv'):
            ra = list(csv.reader(l for l in open(pa) if not l.startswith('#'))); rb = list(csv.reader(l for l in open(pb) if not l.startswith('#')))
            if len(ra) != len(rb): acc.append((math.inf, f'rows {len(ra)} vs {len(rb)}'))
            for i, (x, y) in enumerate(zip(ra, rb)):
                for j, (u, v) in enumerate(zip(x, y)):
                    nu, nv = num(u), num(v)
                    if nu is not None and nv is not None:
                        d = abs(nu - nv) / max(abs(nu), abs(nv), 1e-6)
                        if d > 0: acc.append((d, f'row {i} col {j} {u} vs {v}'))
                    elif u != v: acc.append((math.inf, f'row {i} col {j} {u!r} vs {v!r}'))
        elif f.endswith(('.log', '.png', '.html', '.svg', '.kml', '.gpx', '.geojson', '.toml')):
            continue
        if acc:
            acc.sort(key=lambda t: -t[0]); worst.append((acc[0][0], rel, acc[0][1], len(acc)))
worst.sort(key=lambda t: -t[0])
for w in worst[:40]: print(f'{w[0]:.3g}\t{w[1]}\t{w[2]}\t({w[3]} diffs)')
if not worst: print('identical (numerically, ignoring timings)')
