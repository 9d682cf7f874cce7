//! Set-up shared by the integration tests: `tests/it/main.rs` declares it
//! (`#[path = "../common/mod.rs"] mod common;`) and each test module that
//! needs it says `use crate::common;`. Not every item is used, hence the
//! `dead_code` allowance.
#![allow(dead_code)]

pub mod parallel;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use waymark::matching::{along_route, SyntheticTrack, TrackModel};
use waymark::network::{LoadOptions, Network};
use waymark::route::plan_route;

/// A path inside the repository.
pub fn repo(p: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(p)
}

/// A committed real trace or map (tests/data/real, see its README), as a
/// command-line argument.
pub fn real_data(name: &str) -> String {
    repo("tests/data/real").join(name).display().to_string()
}

/// The real `waymark` binary, not yet run.
pub fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_waymark"))
}

/// Runs the real `waymark` binary with `args` in `dir`.
pub fn run(args: &[&str], dir: &Path) -> Output {
    bin()
        .args(args)
        .current_dir(dir)
        .output()
        .expect("binary runs")
}

/// The bundled Helsinki map with the default load options.
pub fn helsinki() -> Network {
    Network::load(&repo("maps/helsinki.osm.pbf"), &LoadOptions::default()).unwrap()
}

/// Six seeded drives between random nodes of `net` at least 1.5 km apart,
/// each as tracks with a fix every `spacing` metres (seeded by `seed`; 10
/// m/s, no drift, GNSS-like noise of 5 m per axis, no heading): the sparse
/// tracks of tests/it/matching_sparse.rs and tests/it/matching_independent.rs.
/// Each: a label ("route R, S m apart"), the route's length (m), the track.
pub fn sparse_drives(net: &Network, spacings: &[(f64, u64)]) -> Vec<(String, f64, SyntheticTrack)> {
    use rand::{Rng, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(15);
    let lat_lon = |e: [f64; 2]| {
        let g = net.frame.to_geodetic([e[0], e[1], 0.0]);
        [g.lat_deg(), g.lon_deg()]
    };
    let mut routes = Vec::new();
    while routes.len() < 6 {
        let a = net.nodes[rng.random_range(0..net.nodes.len())].enu;
        let b = net.nodes[rng.random_range(0..net.nodes.len())].enu;
        if (a[0] - b[0]).hypot(a[1] - b[1]) < 1500.0 {
            continue;
        }
        if let Ok(r) = plan_route(net, &[lat_lon(a), lat_lon(b)]) {
            routes.push(r);
        }
    }
    let mut out = Vec::new();
    for (r, route) in routes.iter().enumerate() {
        for &(spacing, seed) in spacings {
            let track = along_route(
                net,
                route,
                &TrackModel {
                    spacing_m: spacing,
                    speed_mps: 10.0,
                    drift_max_m: 0.0,
                    noise_sigma_m: 5.0,
                    heading_sigma_deg: None,
                    seed,
                },
            );
            out.push((
                format!("route {r}, {spacing} m apart"),
                route.length_m,
                track,
            ));
        }
    }
    out
}

/// The error figures of `simulate --json` that a diverged or overflowed run
/// would turn into NaN (written as null).
pub const ERROR_FIGURES: [&str; 3] = [
    "max_horizontal_error_m",
    "rms_horizontal_error_m",
    "p95_horizontal_error_m",
];

/// A `simulate --json` run that must have succeeded with finite figures
/// ([`ERROR_FIGURES`] and `final_error_enu_m`): its JSON object.
pub fn succeeded_finite(out: &Output) -> serde_json::Value {
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    for k in ERROR_FIGURES {
        assert!(v[k].as_f64().is_some_and(f64::is_finite), "{k} = {}", v[k]);
    }
    for x in v["final_error_enu_m"].as_array().unwrap() {
        assert!(
            x.as_f64().is_some_and(f64::is_finite),
            "final_error_enu_m holds {x}"
        );
    }
    v
}

/// Exit 1 with one error line holding every one of `needles`, and no long
/// run of digits (a number printed in full).
pub fn fails_with(out: &Output, needles: &[&str]) -> String {
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert_eq!(stderr.trim_end().lines().count(), 1, "{stderr}");
    assert!(stderr.starts_with("waymark: error: "), "{stderr}");
    for n in needles {
        assert!(stderr.contains(n), "{n:?} not in {stderr}");
    }
    assert!(!stderr.contains("0000000000000000000000000"), "{stderr}");
    stderr
}
