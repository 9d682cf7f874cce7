//! A restarted HMM matcher (`HmmMatcher::restart`, what `match_rows` does
//! between the tracks of a file, keeping its buffers and network searches)
//! matches the next track exactly as a fresh matcher does: the same points,
//! confidences and breaks, whatever the previous track left behind (here an
//! off-road fix, a held break, a drift estimate, a full lag window).

use waymark::matching::{
    along_route, match_track, Fix, HmmMatcher, HmmParams, Matcher, TrackModel,
};
use waymark::network::{LoadOptions, Network};
use waymark::route::plan_route;

fn helsinki() -> Network {
    let p = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("maps/helsinki.osm.pbf");
    Network::load(&p, &LoadOptions::default()).unwrap()
}

fn track(net: &Network, from: [f64; 2], to: [f64; 2], seed: u64) -> Vec<Fix> {
    let route = plan_route(net, &[from, to]).unwrap();
    let model = TrackModel {
        spacing_m: 7.0,
        speed_mps: 10.0,
        drift_max_m: 30.0,
        noise_sigma_m: 3.0,
        heading_sigma_deg: None,
        seed,
    };
    along_route(net, &route, &model).fixes
}

#[test]
fn a_restarted_matcher_matches_as_a_fresh_one() {
    let net = helsinki();
    let mut a = track(&net, [60.1660, 24.9380], [60.1770, 24.9510], 3);
    // The first track ends off the map: the matcher holds an off-road break
    // for a next fix that never comes.
    let last = *a.last().unwrap();
    a.push(Fix {
        t_s: last.t_s + 1.0,
        enu: [last.enu[0] + 5_000.0, last.enu[1] + 5_000.0],
        heading_rad: None,
    });
    let b = track(&net, [60.1770, 24.9510], [60.1675, 24.9490], 4);
    assert!(a.len() > 200 && b.len() > 100, "{} {}", a.len(), b.len());
    let pa = HmmParams::default();
    // Other parameters for the second track, as a file's tracks get their
    // own from their σ̂.
    let pb = HmmParams {
        search_radius_m: 150.0,
        sigma_m: 7.0,
        drift_sigma_m: 12.0,
        ..HmmParams::default()
    };
    let mut fresh = HmmMatcher::new(&net, pb);
    let want = match_track(&mut fresh, &b);
    let mut m = HmmMatcher::new(&net, pa);
    let first = match_track(&mut m, &a);
    // Unmatched, and a break held for the next fix (recorded only when one
    // is matched: a restart must forget it).
    assert!(!first.last().unwrap().state.is_matched());
    assert!(m.breaks().is_empty());
    m.restart(pb);
    let got = match_track(&mut m, &b);
    assert_eq!(got.len(), want.len());
    for (g, w) in got.iter().zip(&want) {
        assert_eq!(g, w);
    }
    assert_eq!(m.breaks(), fresh.breaks());
    assert!(want.iter().filter(|p| p.state.is_matched()).count() > b.len() * 9 / 10);
}
