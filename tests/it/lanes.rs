//! The vehicle in its lane (issue 12, point 1): the truth of a map route
//! drives a lane of its direction on the `drive_side` of the road, with
//! lateral wander; bad `[vehicle]` lane settings fail with one line.

use std::path::Path;
use std::process::Command;
use waymark::network::{lane_offset_m, DriveSide};
use waymark::sim::{Scenario, TruthSource};

const TOUR: &str = "scenarios/helsinki-tour-map-matching.toml";

/// The scenario `TOUR` with `extra` lines added to its `[vehicle]`.
fn tour_with(dir: &Path, extra: &str) -> Scenario {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(root.join(TOUR)).unwrap().replace(
        "../maps/helsinki.osm.pbf",
        &root.join("maps/helsinki.osm.pbf").display().to_string(),
    );
    let p = dir.join("tour.toml");
    std::fs::write(&p, format!("{text}\n[vehicle]\n{extra}\n")).unwrap();
    Scenario::load(&p).unwrap()
}

/// Signed lateral offsets (m, right of travel) of the truth from the
/// route's centre polyline, once a second while moving, with the lane
/// offset the road's attributes give there for `side` (kerb lane).
fn offsets(scn: &Scenario, side: DriveSide) -> Vec<(f64, f64, bool)> {
    let truth = TruthSource::new(scn).unwrap();
    let route = truth.route().unwrap().clone();
    let net = truth.network().unwrap().clone();
    let total = truth.samples().last().unwrap().distance_m;
    let scale = route.length_m / total;
    let v = &route.vertices;
    let mut out = Vec::new();
    for a in truth.samples().step_by(100) {
        let sp = a.state.v[0].hypot(a.state.v[1]);
        if sp < 3.0 {
            continue;
        }
        let p = net.frame.to_enu(&waymark::geodesy::Geodetic {
            lat: a.state.lat,
            lon: a.state.lon,
            height: 0.0,
        });
        let c = a.distance_m * scale;
        // Nearest segment of the polyline within ±80 m of chainage (the
        // tour passes some roads twice, in both directions).
        let mut best: Option<(f64, f64)> = None;
        for w in v.windows(2) {
            if w[1].chainage_m < c - 80.0 || w[0].chainage_m > c + 80.0 {
                continue;
            }
            let (a0, b0) = (w[0].enu, w[1].enu);
            let d = [b0[0] - a0[0], b0[1] - a0[1]];
            let l2 = d[0] * d[0] + d[1] * d[1];
            if l2 < 1e-6 {
                continue;
            }
            let t = (((p[0] - a0[0]) * d[0] + (p[1] - a0[1]) * d[1]) / l2).clamp(0.0, 1.0);
            let q = [a0[0] + t * d[0], a0[1] + t * d[1]];
            let dist = (p[0] - q[0]).hypot(p[1] - q[1]);
            // Right of the segment's direction (the direction of travel).
            let cross = (d[1] * (p[0] - a0[0]) - d[0] * (p[1] - a0[1])) / l2.sqrt();
            if best.is_none_or(|b| dist < b.0) {
                best = Some((dist, cross));
            }
        }
        let Some((_, cross)) = best else { continue };
        let road = &net.roads[route.span_at(c).road as usize].attributes;
        out.push((
            cross,
            lane_offset_m(road, side, 0),
            !road.oneway.is_oneway(),
        ));
    }
    out
}

fn median(mut x: Vec<f64>) -> f64 {
    x.sort_by(f64::total_cmp);
    x[x.len() / 2]
}

/// Right-hand traffic: the truth keeps right of the centre line, at the
/// lane offset the map's roads give (1.5–1.75 m on Helsinki's two-way
/// streets, 0 on one-way streets); left-hand traffic mirrors it. Measured
/// on seed 1: median offset 1.44 m right / −1.43 m left; median distance
/// from the expected kerb-lane offset 0.27 m; on two-way roads 97 % / 95 %
/// of the samples on the drive side. Tolerances: the offset is
/// measured against the unsmoothed centre polyline (corners are cut by
/// metres, so the 95th percentile of the difference is large and not
/// asserted), and lane changes on multi-lane roads put the vehicle a lane
/// away from the kerb lane for part of the tour, so only the median and
/// the share on the expected side are asserted.
#[test]
fn the_truth_drives_in_its_lane_on_the_drive_side() {
    let dir = tempfile::tempdir().unwrap();
    let right = offsets(&tour_with(dir.path(), ""), DriveSide::Right);
    let left = offsets(
        &tour_with(dir.path(), "drive_side = \"left\""),
        DriveSide::Left,
    );
    assert!(right.len() > 1500, "{}", right.len());
    let mr = median(right.iter().map(|x| x.0).collect());
    let ml = median(left.iter().map(|x| x.0).collect());
    let dev = median(right.iter().map(|x| (x.0 - x.1).abs()).collect());
    eprintln!(
        "median offset right {mr:.2} m, left {ml:.2} m; median |offset − kerb lane| {dev:.2} m"
    );
    assert!(mr > 1.0 && mr < 2.5, "{mr}");
    assert!(ml < -1.0 && ml > -2.5, "{ml}");
    assert!(dev < 0.6, "{dev}");
    // On two-way roads, nearly always on the drive side (the rest: corners
    // cut against the unsmoothed centre polyline, where the nearest segment
    // is the crossing road's).
    let side = |v: &[(f64, f64, bool)], s: f64| {
        let on: Vec<_> = v.iter().filter(|x| x.2).collect();
        on.iter().filter(|x| x.0 * s > 0.0).count() as f64 / on.len() as f64
    };
    eprintln!(
        "two-way share on the drive side {:.3} / {:.3}",
        side(&right, 1.0),
        side(&left, -1.0)
    );
    assert!(side(&right, 1.0) > 0.9, "{}", side(&right, 1.0));
    assert!(side(&left, -1.0) > 0.9, "{}", side(&left, -1.0));
}

/// The wander: with `lane_wander_m = 0` the truth sits on the lane centre
/// (median |offset − lane| small), with 1 m it spreads more; the spread of
/// the difference between the two drives of the same seed is the wander
/// itself (the lanes and lane changes are drawn first, so they agree): its
/// standard deviation should be near 1 m (measured 1.10 m on seed 1) (0.7–1.3: a Gauss–Markov process
/// correlated over 60 m sampled along a 15 km drive has ~250 independent
/// stretches, so the sample σ is within ~5 %; the Catmull–Rom
/// interpolation between knots lowers the variance a little, and the
/// re-smoothed path cuts some of it at bends).
#[test]
fn lane_wander_has_its_sigma() {
    let dir = tempfile::tempdir().unwrap();
    let a = offsets(
        &tour_with(dir.path(), "lane_wander_m = 0"),
        DriveSide::Right,
    );
    let b = offsets(
        &tour_with(dir.path(), "lane_wander_m = 1.0"),
        DriveSide::Right,
    );
    let n = a.len().min(b.len());
    // The two drives differ in length by the wander's few centimetres per
    // hundred metres: compare by index only where both are on straight
    // stretches of the same road (the lane offsets agree).
    let d: Vec<f64> = (0..n)
        .filter(|&i| (a[i].1 - b[i].1).abs() < 1e-9)
        .map(|i| b[i].0 - a[i].0)
        .filter(|x| x.abs() < 5.0)
        .collect();
    let m = d.iter().sum::<f64>() / d.len() as f64;
    let sd = (d.iter().map(|x| (x - m).powi(2)).sum::<f64>() / d.len() as f64).sqrt();
    eprintln!("wander: {} samples, mean {m:.2} m, σ {sd:.2} m", d.len());
    assert!(sd > 0.7 && sd < 1.3, "{sd}");
}

/// The same seed gives the same lane path; another seed another.
#[test]
fn lane_paths_are_seeded() {
    let dir = tempfile::tempdir().unwrap();
    let last = |extra: &str| {
        let scn = tour_with(dir.path(), extra);
        let t = TruthSource::new(&scn).unwrap();
        let a = t.samples().last().unwrap();
        (a.distance_m, a.state.lat, a.state.lon)
    };
    assert_eq!(last(""), last(""));
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(root.join(TOUR)).unwrap().replace(
        "../maps/helsinki.osm.pbf",
        &root.join("maps/helsinki.osm.pbf").display().to_string(),
    );
    let p = dir.path().join("seed2.toml");
    std::fs::write(&p, format!("seed = 2\n{text}")).unwrap();
    let scn = Scenario::load(&p).unwrap();
    let t = TruthSource::new(&scn).unwrap();
    let a = t.samples().last().unwrap();
    assert_ne!(last("").0, a.distance_m);
}

/// Bad `[vehicle]` lane settings: one line naming the file and the field,
/// exit code 1, no panic.
#[test]
fn bad_lane_settings_fail_with_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let map = Path::new(env!("CARGO_MANIFEST_DIR")).join("maps/helsinki.osm.pbf");
    for (extra, field) in [
        ("drive_side = \"middle\"", "vehicle.drive_side"),
        ("drive_side = 1", "vehicle.drive_side"),
        ("lane_wander_m = -0.3", "vehicle.lane_wander_m"),
        ("lane_wander_m = nan", "vehicle.lane_wander_m"),
        ("lane_wander_m = inf", "vehicle.lane_wander_m"),
    ] {
        let p = dir.path().join("bad-lane.toml");
        std::fs::write(
            &p,
            format!(
                "name = \"bad\"\n[map]\npath = \"{}\"\n[[route]]\nwaypoints = [[60.1660, 24.9380], [60.1770, 24.9510]]\n[imu]\nrate_hz = 100\n[vehicle]\n{extra}\n",
                map.display()
            ),
        )
        .unwrap();
        let out = Command::new(env!("CARGO_BIN_EXE_waymark"))
            .args(["simulate", "-q", "--out"])
            .arg(dir.path().join("out"))
            .arg(&p)
            .output()
            .unwrap();
        assert_eq!(out.status.code(), Some(1), "{extra}");
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(err.trim().lines().count(), 1, "{extra}: {err}");
        assert!(
            err.contains("bad-lane.toml") && err.contains(field),
            "{extra}: {err}"
        );
        assert!(!err.contains("panicked"), "{err}");
    }
}
