//! Routes on the bundled Helsinki map: shortest paths honour one-way roads and
//! agree with an independent Dijkstra (petgraph) over the same directed graph.

use petgraph::algo::dijkstra;
use petgraph::graph::{DiGraph, NodeIndex};
use proptest::prelude::*;
use std::path::Path;
use std::sync::OnceLock;
use waymark::network::{LoadOptions, Network};
use waymark::route::{
    plan_route, shortest_path, shortest_path_with, Landmarks, SectionPoint, DEFAULT_LANDMARKS,
};

fn helsinki() -> &'static Network {
    static NET: OnceLock<Network> = OnceLock::new();
    NET.get_or_init(|| {
        let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("maps/helsinki.osm.pbf");
        Network::load(&p, &LoadOptions::default()).expect("bundled map loads")
    })
}

fn landmarks() -> &'static Landmarks {
    static LM: OnceLock<Landmarks> = OnceLock::new();
    LM.get_or_init(|| Landmarks::build(helsinki(), DEFAULT_LANDMARKS))
}

fn node_graph(net: &Network) -> DiGraph<(), f64, u32> {
    let mut g = DiGraph::with_capacity(net.nodes.len(), net.sections.len() * 2);
    for _ in 0..net.nodes.len() {
        g.add_node(());
    }
    for s in &net.sections {
        let (a, b) = (
            NodeIndex::new(s.start as usize),
            NodeIndex::new(s.end as usize),
        );
        if s.oneway.allows_forward() {
            g.add_edge(a, b, s.length_m);
        }
        if s.oneway.allows_backward() {
            g.add_edge(b, a, s.length_m);
        }
    }
    g
}

/// The point at a node, as the start or end of one of its sections.
fn point_at_node(net: &Network, node: u32) -> SectionPoint {
    let inc = net.topology.incidences(node)[0];
    let s = &net.sections[inc.section as usize];
    SectionPoint {
        section: inc.section,
        offset_m: if s.start == node { 0.0 } else { s.length_m },
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]
    #[test]
    fn shortest_path_matches_reference_dijkstra(a in 0usize..10_000, b in 0usize..10_000) {
        let net = helsinki();
        let (a, b) = ((a % net.nodes.len()) as u32, (b % net.nodes.len()) as u32);
        let reference = dijkstra(&node_graph(net), NodeIndex::new(a as usize), Some(NodeIndex::new(b as usize)), |e| *e.weight());
        let expected = reference.get(&NodeIndex::new(b as usize)).copied();
        let got = shortest_path(net, point_at_node(net, a), point_at_node(net, b), None);
        match (expected, got) {
            (Some(e), Some((pieces, len))) => {
                // Same graph, same weights: equal up to float summation order (1 mm).
                prop_assert!((e - len).abs() < 1e-3, "reference {e} m, route {len} m");
                // Every piece is travelled in a permitted direction and pieces join up.
                for w in pieces.windows(2) {
                    let (p, q) = (w[0], w[1]);
                    let sp = &net.sections[p.0.section as usize];
                    let sq = &net.sections[q.0.section as usize];
                    let arrive = if p.0.forward { sp.end } else { sp.start };
                    let depart = if q.0.forward { sq.start } else { sq.end };
                    prop_assert_eq!(arrive, depart);
                }
                for (d, from, to) in &pieces {
                    let s = &net.sections[d.section as usize];
                    if (to - from).abs() > 0.0 {
                        let allowed = if d.forward { s.oneway.allows_forward() } else { s.oneway.allows_backward() };
                        prop_assert!(allowed, "section {} driven against its one-way direction", d.section);
                        prop_assert_eq!(d.forward, to > from);
                    }
                }
            }
            (None, None) => {}
            (e, g) => prop_assert!(false, "reference {:?} vs route {:?}", e, g.map(|x| x.1)),
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]
    /// Landmarks bound every distance from below (∞ only where no path
    /// exists), and A* guided by them finds the reference's length between
    /// any two points, nodes or not, in the map's main part or not.
    #[test]
    fn landmark_bounds_hold_and_guided_paths_are_shortest(
        a in 0usize..100_000, b in 0usize..100_000, fa in 0.0f64..1.0, fb in 0.0f64..1.0,
    ) {
        let net = helsinki();
        let lm = landmarks();
        prop_assert_eq!(lm.nodes().len(), DEFAULT_LANDMARKS);
        let g = node_graph(net);
        let (na, nb) = ((a % net.nodes.len()) as u32, (b % net.nodes.len()) as u32);
        let reference = dijkstra(&g, NodeIndex::new(na as usize), Some(NodeIndex::new(nb as usize)), |e| *e.weight());
        let bound = lm.lower_bound(na, nb);
        if let Some(&d) = reference.get(&NodeIndex::new(nb as usize)) {
            // Exact distances summed in different orders: 1 mm of slack.
            prop_assert!(bound <= d + 1e-3, "bound {bound} m above the distance {d} m");
        }
        if bound.is_infinite() {
            prop_assert!(!reference.contains_key(&NodeIndex::new(nb as usize)));
        }
        // Points inside sections: the plain search is the reference here
        // (itself checked against petgraph above).
        let (sa, sb) = (a % net.sections.len(), b % net.sections.len());
        let pa = SectionPoint { section: sa as u32, offset_m: fa * net.sections[sa].length_m };
        let pb = SectionPoint { section: sb as u32, offset_m: fb * net.sections[sb].length_m };
        for dir in [None, Some(true), Some(false)] {
            let plain = shortest_path(net, pa, pb, dir).map(|p| p.1);
            let guided = shortest_path_with(net, Some(lm), pa, pb, dir).map(|p| p.1);
            match (plain, guided) {
                (Some(x), Some(y)) => prop_assert!((x - y).abs() < 1e-3, "plain {x} m, guided {y} m"),
                (None, None) => {}
                (x, y) => prop_assert!(false, "plain {:?} vs guided {:?}", x, y),
            }
        }
    }
}

#[test]
fn route_through_waypoints_has_consistent_chainage() {
    let net = helsinki();
    // Two points across the extract, about 1.4 km apart.
    let route = plan_route(net, &[[60.1660, 24.9380], [60.1770, 24.9510]]).unwrap();
    let straight = {
        let (a, b) = (route.waypoints[0].enu, route.waypoints[1].enu);
        (a[0] - b[0]).hypot(a[1] - b[1])
    };
    assert!(route.length_m >= straight - 1e-6);
    assert!(
        route.length_m < 3.0 * straight,
        "detour too long: {} m vs {straight} m",
        route.length_m
    );
    for w in route.vertices.windows(2) {
        let d = (w[1].enu[0] - w[0].enu[0]).hypot(w[1].enu[1] - w[0].enu[1]);
        assert!((w[1].chainage_m - w[0].chainage_m - d).abs() < 1e-6);
    }
    let last_span = route.spans.last().unwrap();
    assert!((last_span.end_chainage_m - route.length_m).abs() < 1e-3);
    // Interpolation lands on the polyline's vertices.
    let v = route.vertices[route.vertices.len() / 2];
    let p = route.position_at(v.chainage_m);
    assert!((p[0] - v.enu[0]).hypot(p[1] - v.enu[1]) < 1e-6);
}

#[test]
fn waypoint_off_the_map_is_an_error() {
    let net = helsinki();
    let err = plan_route(net, &[[60.1675, 24.9490], [60.30, 25.20]]).unwrap_err();
    let msg = err.to_string();
    assert!(
        msg.contains("waypoint 2") && msg.contains("from the nearest road"),
        "{msg}"
    );
    assert!(plan_route(net, &[[60.1675, 24.9490]]).is_err());
    assert!(plan_route(net, &[[f64::NAN, 24.9], [60.1675, 24.9490]]).is_err());
}

/// With no landmark (a map too large for their memory cap gets fewer, down
/// to none) the guided search is the plain one.
#[test]
fn no_landmarks_is_the_straight_line_search() {
    let net = helsinki();
    let none = Landmarks::build(net, 0);
    assert!(none.nodes().is_empty());
    assert_eq!(none.lower_bound(0, 1), 0.0);
    for i in 0..50u32 {
        let (a, b) = (
            (i * 7919) % net.nodes.len() as u32,
            (i * 104_729 + 13) % net.nodes.len() as u32,
        );
        let (pa, pb) = (point_at_node(net, a), point_at_node(net, b));
        let plain = shortest_path(net, pa, pb, None).map(|p| p.1);
        let guided = shortest_path_with(net, Some(&none), pa, pb, None).map(|p| p.1);
        assert_eq!(plain, guided, "nodes {a} → {b}");
    }
}
