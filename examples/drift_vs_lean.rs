//! The drift model against the lean (independent) model on synthetic
//! tracks with and without a slowly varying drift, at fix spacings from
//! 1 m to 300 m, with a residual-correlation statistic per track: the
//! measurement behind BENCHMARKS.md, "Could the matcher choose its model
//! from the track?" (issue 15). Complete-path precision and recall by
//! length, both models with `waymark match`'s defaults from the track.
//!
//! Usage: cargo run --release --example drift_vs_lean [noisy]
//!
//! With `noisy`: white noise of 10-60 m with and without drift, at 10 m and
//! 200 m spacing, and σ̂ per track (the error `waymark match` estimates from
//! the track) in place of z: the measurement behind "Could σ̂ choose the
//! model?" in the same BENCHMARKS.md section.
//!
//! Tracks: the U routes over parallel two-way roads of
//! tests/it/matching_accuracy.rs on the Gothenburg map, and eight seeded
//! drives between random Helsinki nodes at least 1.2 km apart. z: per
//! track, Σ rᵢ·rᵢ₊₁ / √Σ(rᵢ·rᵢ₊₁)², r the vector from a fix's nearest road
//! point to the fix (about N(0, 1) when consecutive errors are independent).

#[path = "../tests/common/parallel.rs"]
mod parallel;

use waymark::matching::cpath::complete_path;
use waymark::matching::evaluate::score;
use waymark::matching::options::{self, MatchOptions};
use waymark::matching::path_out::path_lengths;
use waymark::matching::{along_route, match_track, HmmMatcher, HmmModel, Matcher, TrackModel};
use waymark::network::{LoadOptions, Network};
use waymark::route::{plan_route, Route};

fn parallel_routes(net: &Network) -> Vec<Route> {
    parallel::u_routes(net, &parallel::pairs(net))
}

fn random_routes(net: &Network, n: usize, min_m: f64) -> Vec<Route> {
    use rand::{Rng, SeedableRng};
    let lat_lon = |e: [f64; 2]| {
        let g = net.frame.to_geodetic([e[0], e[1], 0.0]);
        [g.lat_deg(), g.lon_deg()]
    };
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(77);
    let mut out = Vec::new();
    while out.len() < n {
        let a = net.nodes[rng.random_range(0..net.nodes.len())].enu;
        let b = net.nodes[rng.random_range(0..net.nodes.len())].enu;
        if (a[0] - b[0]).hypot(a[1] - b[1]) < min_m {
            continue;
        }
        if let Ok(r) = plan_route(net, &[lat_lon(a), lat_lon(b)]) {
            out.push(r);
        }
    }
    out
}

fn run(name: &str, net: &Network, routes: &[Route], noisy: bool) {
    let drift = MatchOptions::default();
    let lean = MatchOptions {
        model: HmmModel::Independent,
        ..MatchOptions::default()
    };
    let (spacings, conditions): (&[f64], &[(f64, f64)]) = if noisy {
        (
            &[10.0, 200.0],
            &[
                (0.0, 10.0),
                (0.0, 30.0),
                (0.0, 60.0),
                (20.0, 50.0),
                (50.0, 50.0),
            ],
        )
    } else {
        (
            &[1.0, 10.0, 30.0, 50.0, 100.0, 170.0, 300.0],
            &[(30.0, 2.0), (10.0, 2.0), (0.0, 5.0)],
        )
    };
    for &spacing in spacings {
        for &(dmax, noise) in conditions {
            let mut acc = [[0.0f64; 4]; 2];
            let mut zs = Vec::new();
            for (k, route) in routes.iter().enumerate() {
                let t = along_route(
                    net,
                    route,
                    &TrackModel {
                        spacing_m: spacing,
                        speed_mps: 10.0,
                        drift_max_m: dmax,
                        noise_sigma_m: noise,
                        heading_sigma_deg: None,
                        seed: 500 + k as u64,
                    },
                );
                zs.push(if noisy {
                    options::estimate_sigma_m(net, &t.fixes).unwrap_or(f64::NAN)
                } else {
                    stat(net, &t.fixes)
                });
                for (j, o) in [drift, lean].iter().enumerate() {
                    let params = o.hmm_params(net, &t.fixes);
                    let mut m = HmmMatcher::new(net, params);
                    let pts = match_track(&mut m, &t.fixes);
                    let br = m.breaks().to_vec();
                    let path = complete_path(net, &pts, &br, &params);
                    let s = score(&path_lengths(net, &[&path]), &t.truth);
                    acc[j][0] += s.precision_length * s.matched_length_m;
                    acc[j][1] += s.matched_length_m;
                    acc[j][2] += s.recall_length * s.truth_length_m;
                    acc[j][3] += s.truth_length_m;
                }
            }
            let z: Vec<String> = zs.iter().map(|z| format!("{z:.1}")).collect();
            let label = if noisy { "sigma-hat" } else { "z" };
            println!("{name} sp {spacing} drift {dmax} noise {noise}: drift P {:.3} R {:.3} | lean P {:.3} R {:.3} | {label} {}", acc[0][0]/acc[0][1], acc[0][2]/acc[0][3], acc[1][0]/acc[1][1], acc[1][2]/acc[1][3], z.join(" "));
        }
    }
}

fn resid(net: &Network, p: [f64; 2]) -> Option<[f64; 2]> {
    let mut best = (f64::INFINITY, [0.0; 2]);
    net.grid.for_each_within(p, 300.0, |id, t, d| {
        if d < best.0 {
            let s = &net.segments[id as usize];
            let q = [
                s.a[0] + t * (s.b[0] - s.a[0]),
                s.a[1] + t * (s.b[1] - s.a[1]),
            ];
            best = (d, [p[0] - q[0], p[1] - q[1]]);
        }
    });
    best.0.is_finite().then_some(best.1)
}
fn stat(net: &Network, fixes: &[waymark::matching::Fix]) -> f64 {
    let r: Vec<Option<[f64; 2]>> = fixes.iter().map(|f| resid(net, f.enu)).collect();
    let (mut s, mut s2) = (0.0, 0.0);
    for w in r.windows(2) {
        if let (Some(a), Some(b)) = (w[0], w[1]) {
            let p = a[0] * b[0] + a[1] * b[1];
            s += p;
            s2 += p * p;
        }
    }
    s / s2.sqrt()
}

fn main() {
    let noisy = std::env::args().nth(1).as_deref() == Some("noisy");
    // The real traces: z and σ̂ per track.
    let real = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/real");
    for (map, track) in [
        ("fmm-network.geojson", "fmm-trips.geojson"),
        ("issue-70.osm", "issue-70.gpx"),
        ("issue-13.osm", "issue-13.gpx"),
    ] {
        let net = Network::load(&real.join(map), &LoadOptions::default()).unwrap();
        let (rows, _) = waymark::matching::inputs::read_track_file(&real.join(track)).unwrap();
        for (id, idx) in waymark::matching::track::group_tracks(&rows) {
            let f: Vec<_> = idx
                .iter()
                .map(|&i| waymark::matching::track::to_fix(&net, &rows[i]))
                .collect();
            println!(
                "{track} track {id}: {} fixes, z {:.2}, sigma-hat {:.1} m",
                f.len(),
                stat(&net, &f),
                options::estimate_sigma_m(&net, &f).unwrap_or(f64::NAN)
            );
        }
    }
    let maps = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("maps");
    let g = Network::load(
        &maps.join("gothenburg-roads.geojson"),
        &LoadOptions::default(),
    )
    .unwrap();
    let pr = parallel_routes(&g);
    run("parallel", &g, &pr, noisy);
    let h = Network::load(&maps.join("helsinki.osm.pbf"), &LoadOptions::default()).unwrap();
    let hr = random_routes(&h, 8, 1200.0);
    run("helsinki", &h, &hr, noisy);
}
