//! Map matching feeding the integrated navigator (issue 5, item 4): a 1 h
//! drive through a street grid (100 m blocks, 10 km × 1 km) with a drifting
//! navigator — an industrial-grade IMU (gyro bias 1 °/h, accelerometer bias
//! 300 µg) with an odometer of 0.5 % scale-factor error, no tags —
//! with and without `aiding.map_matching`. The route zig-zags across the
//! grid while progressing 10 km along it, so the scale-factor error grows
//! with the displacement (0.5 % of 10 km = 50 m) and there are turns every few
//! hundred metres.

use std::fmt::Write as _;
use std::path::Path;
use waymark::sim::{simulate, Scenario, TruthSource};

/// A street grid as OSM XML: `rows` × `cols` nodes 100 m apart near 60° N.
fn grid_osm(rows: usize, cols: usize) -> String {
    let dlat = 100.0 / 111_412.0;
    let dlon = 100.0 / (111_412.0 * 60f64.to_radians().cos());
    let id = |r: usize, c: usize| 1 + r * cols + c;
    let mut s = String::from("<?xml version='1.0' encoding='UTF-8'?>\n<osm version='0.6'>\n");
    for r in 0..rows {
        for c in 0..cols {
            let _ = writeln!(
                s,
                "<node id='{}' lat='{:.8}' lon='{:.8}'/>",
                id(r, c),
                60.0 + r as f64 * dlat,
                24.0 + c as f64 * dlon
            );
        }
    }
    let mut way = 1;
    for r in 0..rows {
        let _ = writeln!(s, "<way id='{way}'>");
        for c in 0..cols {
            let _ = writeln!(s, "<nd ref='{}'/>", id(r, c));
        }
        s.push_str("<tag k='highway' v='residential'/></way>\n");
        way += 1;
    }
    for c in 0..cols {
        let _ = writeln!(s, "<way id='{way}'>");
        for r in 0..rows {
            let _ = writeln!(s, "<nd ref='{}'/>", id(r, c));
        }
        s.push_str("<tag k='highway' v='residential'/></way>\n");
        way += 1;
    }
    s.push_str("</osm>\n");
    s
}

fn scenario(dir: &Path, map_matching: bool) -> std::path::PathBuf {
    let dlat = 100.0 / 111_412.0;
    let dlon = 100.0 / (111_412.0 * 60f64.to_radians().cos());
    // Zig-zag: across the 1 km width, 400 m further along each time.
    let waypoints: Vec<String> = (0..=25)
        .map(|i| {
            let r = if i % 2 == 1 { 10 } else { 0 };
            let c = 4 * i;
            format!(
                "[{:.8}, {:.8}]",
                60.0 + r as f64 * dlat,
                24.0 + c as f64 * dlon
            )
        })
        .collect();
    let text = format!(
        r#"name = "grid-1h-map-matching-{map_matching}"
requirement_m = 20.0
duration_s = 3600

[map]
path = "grid.osm"

[[route]]
waypoints = [{}]
speed_kmh = 40

[navigator]
mode = "integrated"

[imu]
rate_hz = 100
gyro_bias_dph = [1.0, 1.0, 1.0]
accel_bias_ug = [300, 300, 300]
gyro_arw_dprh = 0.05
accel_vrw_ugprhz = 50

[odometer]
scale_factor_error = 0.005
noise_mps = 0.02
pulse_m = 0.02

[aiding]
odometer = true
baro = true
map_matching = {map_matching}
"#,
        waypoints.join(", ")
    );
    let p = dir.join(format!("grid-{map_matching}.toml"));
    std::fs::write(&p, text).unwrap();
    p
}

/// Figures of run 0: (final horizontal, rms horizontal, rms along, rms across,
/// final along, final across, max horizontal, distance km, max |east|,
/// max |north|).
fn figures(path: &Path) -> ([f64; 10], Option<waymark::sim::FeedCounts>) {
    let scn = Scenario::load(path).unwrap();
    let truth = TruthSource::new(&scn).unwrap();
    let res = simulate(&scn, &truth, 1, 7).unwrap();
    let run = &res.runs[0];
    // Truth direction of travel at each row's time.
    let mut dirs = Vec::with_capacity(run.rows.len());
    let mut samples = truth.samples();
    for row in &run.rows {
        let mut last = None;
        for a in samples.by_ref() {
            let v = a.state.v;
            let sp = v[0].hypot(v[1]);
            if sp > 0.5 {
                last = Some([v[0] / sp, v[1] / sp]);
            }
            if a.t >= row.t_s - 1e-9 {
                break;
            }
        }
        dirs.push(last.or(dirs.last().copied()).unwrap_or([0.0, 1.0]));
    }
    let (mut sh, mut sa, mut sc, mut mx) = (0.0, 0.0, 0.0, 0.0f64);
    let (mut me, mut mn) = (0.0f64, 0.0f64);
    for (row, d) in run.rows.iter().zip(&dirs) {
        let along = row.east_m * d[0] + row.north_m * d[1];
        let across = row.east_m * d[1] - row.north_m * d[0];
        sh += row.horizontal_m * row.horizontal_m;
        sa += along * along;
        sc += across * across;
        mx = mx.max(row.horizontal_m);
        me = me.max(row.east_m.abs());
        mn = mn.max(row.north_m.abs());
    }
    let n = run.rows.len() as f64;
    let last = run.rows.last().unwrap();
    let d = dirs.last().unwrap();
    (
        [
            last.horizontal_m,
            (sh / n).sqrt(),
            (sa / n).sqrt(),
            (sc / n).sqrt(),
            last.east_m * d[0] + last.north_m * d[1],
            last.east_m * d[1] - last.north_m * d[0],
            mx,
            last.distance_m / 1000.0,
            me,
            mn,
        ],
        run.map_feed,
    )
}

#[test]
fn map_matching_bounds_the_drift_of_a_one_hour_street_grid_drive() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("grid.osm"), grid_osm(11, 101)).unwrap();
    let (off, none) = figures(&scenario(dir.path(), false));
    let (on, feed) = figures(&scenario(dir.path(), true));
    assert!(none.is_none());
    let feed = feed.expect("the feed ran");
    eprintln!("feed: {feed:?}");
    for (name, f) in [("without map matching", off), ("with map matching", on)] {
        eprintln!(
            "{name}: {:.1} km; final horizontal {:.1} m (along {:.1}, across {:.1}); rms horizontal {:.1} m (along {:.1}, across {:.1}); max {:.1} m (east {:.1}, north {:.1})",
            f[7], f[0], f[4], f[5], f[1], f[2], f[3], f[6], f[8], f[9]
        );
    }
    assert!(off[7] > 30.0, "{} km: not a 1 h drive", off[7]);
    // The drift without matching is what the scale-factor error makes it.
    assert!(off[0] > 20.0, "final {:.1} m without matching", off[0]);
    // With matching: smaller at the end and throughout.
    assert!(
        on[0] < 0.5 * off[0],
        "final {:.1} vs {:.1} m",
        on[0],
        off[0]
    );
    assert!(on[1] < 0.5 * off[1], "rms {:.1} vs {:.1} m", on[1], off[1]);
    // Across the road the fixes (σ 3 m) hold the error to a few metres.
    assert!(on[3] < 5.0, "rms across {:.1} m", on[3]);
    // Most fixes pass the filter's gate; the matcher rarely loses the road.
    assert!(
        feed.fed > 3000 && feed.accepted as f64 > 0.9 * feed.fed as f64,
        "{feed:?}"
    );
}

/// Map matching needs a map route and the integrated navigator.
#[test]
fn map_matching_needs_a_map_route_and_the_integrated_navigator() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("motion.toml");
    std::fs::write(
        &p,
        r#"name = "m"
[[route]]
start = { lat = 60.0, lon = 24.0, height_m = 0.0, heading_deg = 0.0 }
motion = [ { kind = "cruise", duration_s = 10 } ]
[navigator]
mode = "integrated"
[aiding]
odometer = true
map_matching = true
"#,
    )
    .unwrap();
    let scn = Scenario::load(&p).unwrap();
    let truth = TruthSource::new(&scn).unwrap();
    let e = simulate(&scn, &truth, 1, 1).unwrap_err().to_string();
    assert!(e.contains("map_matching needs a map route"), "{e}");
    std::fs::write(dir.path().join("grid.osm"), grid_osm(11, 101)).unwrap();
    let q = dir.path().join("dr.toml");
    let text = std::fs::read_to_string(scenario(dir.path(), true))
        .unwrap()
        .replace("mode = \"integrated\"", "mode = \"dead_reckoning\"");
    std::fs::write(&q, text).unwrap();
    let scn = Scenario::load(&q).unwrap();
    let truth = TruthSource::new(&scn).unwrap();
    let e = simulate(&scn, &truth, 1, 1).unwrap_err().to_string();
    assert!(e.contains("used only by navigator.mode"), "{e}");
}

/// The same comparison on a real map: the bundled Helsinki route there and
/// back (one-way streets, tunnels, short blocks) with the same drifting
/// navigator.
#[test]
fn map_matching_helps_on_the_helsinki_route() {
    let dir = tempfile::tempdir().unwrap();
    let map = Path::new(env!("CARGO_MANIFEST_DIR")).join("maps/helsinki.osm.pbf");
    let write = |mm: bool| {
        let p = dir.path().join(format!("h-{mm}.toml"));
        std::fs::write(
            &p,
            format!(
                r#"name = "helsinki-mm-{mm}"
[map]
path = "{}"
# A perfect map (issue 12): this test checks that the feed's fixes pull the
# navigator towards the road on a short (~8 min) drive whose dead reckoning
# is already sub-metre; with the default 4.8 m map error the inflated fixes
# (rightly) change nothing there (rms 0.7 vs 0.7 m), which is no test of
# the feed.
geometry_error_m = 0
[[route]]
waypoints = [[60.1660, 24.9380], [60.1770, 24.9510], [60.1660, 24.9380]]
speed_kmh = 40
# The truth in its lane (issue 12) without wander: with it, this 8 min
# drive's result hinges on a few junction events (20 runs, seed 1: wander
# 0.1 / 0.2 / 0.3 / 1.0 m give RMS 0.49 / 0.84 / 0.83 / 0.78 m with map
# matching against 0.84 m without; wrong-road share 3.3–5.6 %), which is
# not what this test checks (that the feed pulls the navigator to its lane).
[vehicle]
lane_wander_m = 0
[navigator]
mode = "integrated"
[imu]
rate_hz = 100
gyro_bias_dph = [1.0, 1.0, 1.0]
accel_bias_ug = [300, 300, 300]
gyro_arw_dprh = 0.05
accel_vrw_ugprhz = 50
[odometer]
scale_factor_error = 0.005
noise_mps = 0.02
pulse_m = 0.02
[aiding]
odometer = true
baro = true
map_matching = {mm}
"#,
                map.display()
            ),
        )
        .unwrap();
        p
    };
    let (off, _) = figures(&write(false));
    let (on, feed) = figures(&write(true));
    let feed = feed.unwrap();
    for (name, f) in [("without", off), ("with", on)] {
        eprintln!(
            "helsinki {name} map matching: {:.1} km; final {:.1} m; rms {:.1} m (along {:.1}, across {:.1}); max {:.1} m",
            f[7], f[0], f[1], f[2], f[3], f[6]
        );
    }
    eprintln!("feed: {feed:?}");
    assert!(on[1] < off[1], "rms {:.1} vs {:.1} m", on[1], off[1]);
    assert!(on[6] < off[6], "max {:.1} vs {:.1} m", on[6], off[6]);
}
