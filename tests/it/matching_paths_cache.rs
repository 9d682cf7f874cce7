//! `NetworkDistances::path_into` when the cache of searches fills up
//! between the searches from a point's two exits: the second search empties
//! the cache (at `CACHE_NODES` = 4096 searches held), dropping the first
//! exit's tree. The path must still be found, and be the one a new cache
//! finds; it used to panic on the missing tree.

use waymark::matching::{NetworkDistances, OnSection};
use waymark::network::{LoadOptions, Network};

/// Searches held when the cache is emptied before the next (paths.rs).
const CACHE_NODES: usize = 4096;

#[test]
fn a_path_is_found_when_the_cache_fills_between_a_points_exits() {
    let p = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("maps/gothenburg-roads.geojson");
    let net = Network::load(&p, &LoadOptions::default()).unwrap();
    assert!(net.nodes.len() > CACHE_NODES + 10, "{}", net.nodes.len());
    // A two-way section (both exits open to a point of unknown direction),
    // and a two-way section leaving its end node.
    let two_way = |s: &waymark::network::Section| {
        s.oneway.allows_forward() && s.oneway.allows_backward() && s.start != s.end
    };
    let (sa, a_sec) = net
        .sections
        .iter()
        .enumerate()
        .find(|(_, s)| two_way(s) && s.length_m > 20.0)
        .unwrap();
    let (sb, b_sec) = net
        .sections
        .iter()
        .enumerate()
        .find(|(k, s)| *k != sa && two_way(s) && s.start == a_sec.end && s.end != a_sec.start)
        .unwrap();
    let a = OnSection {
        section: sa as u32,
        offset_m: a_sec.length_m / 2.0,
        forward: None,
    };
    let b = OnSection {
        section: sb as u32,
        offset_m: b_sec.length_m / 2.0,
        forward: None,
    };
    let bound = 5_000.0;
    let mut want = Vec::new();
    assert!(NetworkDistances::new(&net).path_into(a, b, bound, 0.0, &mut want));
    assert!(want.len() >= 2, "{want:?}");
    // The cache one search short of full, the first exit not searched
    // (both exits are searched in the call, the second empties the cache);
    // then full, the first exit searched before (a cached tree, dropped by
    // the second exit's search).
    for first_cached in [false, true] {
        let mut d = NetworkDistances::new(&net);
        let others: Vec<u32> = (0..net.nodes.len() as u32)
            .filter(|&n| n != a_sec.start && n != a_sec.end)
            .take(CACHE_NODES - 1)
            .collect();
        for &n in &others {
            d.ensure(n, 1.0);
        }
        if first_cached {
            // `exits` lists the end node first (leaving forward).
            assert_eq!(d.exits(a)[0].map(|e| e.0), Some(a_sec.end));
            d.ensure(a_sec.end, bound);
        }
        assert_eq!(d.node_distance(others[0], others[0]), Some(0.0));
        let mut got = Vec::new();
        assert!(d.path_into(a, b, bound, 0.0, &mut got));
        // The cache was emptied during the call (the case under test) ...
        assert_eq!(d.node_distance(others[0], others[0]), None);
        // ... and the path is a new cache's.
        assert_eq!(got, want, "first exit cached: {first_cached}");
    }
}

/// `NetworkDistances::ensure_exits` (what the drift model's transitions
/// call before reading their route-distance matrix) holds every point's
/// searches at once, also when the cache fills part-way: with the cache one
/// search short of full, the second exit's search empties it, which used to
/// drop the first exit's tree, so the matrix read that predecessor's pairs
/// as out of reach.
#[test]
fn every_exit_is_held_when_the_cache_fills_part_way() {
    let p = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("maps/gothenburg-roads.geojson");
    let net = Network::load(&p, &LoadOptions::default()).unwrap();
    assert!(net.nodes.len() > CACHE_NODES + 10, "{}", net.nodes.len());
    // Three two-way sections with six distinct end nodes: six exits.
    let mut points = Vec::new();
    let mut nodes = std::collections::BTreeSet::new();
    for (k, s) in net.sections.iter().enumerate() {
        let two_way = s.oneway.allows_forward() && s.oneway.allows_backward();
        if two_way && s.start != s.end && !nodes.contains(&s.start) && !nodes.contains(&s.end) {
            nodes.insert(s.start);
            nodes.insert(s.end);
            points.push(OnSection {
                section: k as u32,
                offset_m: s.length_m / 2.0,
                forward: None,
            });
            if points.len() == 3 {
                break;
            }
        }
    }
    assert_eq!(nodes.len(), 6);
    let bound = 1_000.0;
    let mut d = NetworkDistances::new(&net);
    let others: Vec<u32> = (0..net.nodes.len() as u32)
        .filter(|n| !nodes.contains(n))
        .take(CACHE_NODES - 1)
        .collect();
    for &n in &others {
        d.ensure(n, 1.0);
    }
    d.ensure_exits(points.iter().copied(), bound);
    // The cache was emptied during the call (the case under test) ...
    assert_eq!(d.node_distance(others[0], others[0]), None);
    // ... and every exit's search is held, as a new cache would hold it.
    for &n in &nodes {
        assert_eq!(d.node_distance(n, n), Some(0.0), "node {n}");
    }
    // Without the cache filling, the same searches and nothing else.
    let mut fresh = NetworkDistances::new(&net);
    fresh.ensure_exits(points.iter().copied(), bound);
    for &n in &nodes {
        assert_eq!(fresh.node_distance(n, n), Some(0.0), "node {n}");
    }
    assert_eq!(fresh.searches, 6);
}
