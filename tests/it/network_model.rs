//! The network model on small hand-made maps whose every figure is known:
//! `tests/data/small.osm` (see the comments below for what each way tests)
//! and `tests/data/small.geojson`.

use std::path::{Path, PathBuf};
use waymark::network::{DirectedSection, LoadOptions, Network, Oneway, SectionEnd};

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(name)
}

fn small() -> Network {
    Network::load(&data("small.osm"), &LoadOptions::default()).unwrap()
}

fn road<'a>(net: &'a Network, id: &str) -> &'a waymark::network::Road {
    net.roads.iter().find(|r| r.attributes.id == id).unwrap()
}

#[test]
fn counts_and_skips() {
    let net = small();
    // 16 ways: 15 with a highway tag; footway, track and area=yes are skipped;
    // way 6 misses node 999 and is kept in two parts.
    assert_eq!(net.report.features_read, 15);
    assert_eq!(net.roads.len(), 12);
    assert_eq!(net.report.skipped.get("not_drivable"), Some(&1));
    assert_eq!(net.report.skipped.get("track_excluded"), Some(&1));
    assert_eq!(net.report.skipped.get("area"), Some(&1));
    assert_eq!(net.report.cut_ways, 1);
    assert!(road(&net, "6").cut_at_extract_edge);
    assert_eq!(net.sections.len(), 14);
    assert_eq!(net.nodes.len(), 17);
    // Way 12 repeats node 40 and has nodes 41 and 42 at one position.
    assert_eq!(net.report.zero_length_segments, 2);
    assert_eq!(net.segments.len(), 18);

    let tracks = Network::load(
        &data("small.osm"),
        &LoadOptions {
            include_tracks: true,
            ..Default::default()
        },
    )
    .unwrap();
    assert_eq!(tracks.roads.len(), 13);
}

#[test]
fn attributes_are_read() {
    let net = small();
    let main = &road(&net, "1").attributes;
    assert_eq!(main.name.as_deref(), Some("Main & First"));
    assert_eq!(main.oneway, Oneway::Both);
    let w2 = &road(&net, "2").attributes;
    assert_eq!(w2.oneway, Oneway::Forward);
    assert!((w2.maxspeed_kmh.unwrap() - 48.280_32).abs() < 1e-3);
    assert_eq!(w2.lanes, Some(2));
    assert!(w2.tunnel);
    assert_eq!(w2.layer, -1);
    assert_eq!(road(&net, "3").attributes.oneway, Oneway::Backward);
    assert_eq!(road(&net, "3").attributes.width_m, Some(7.0));
    assert_eq!(road(&net, "4").attributes.oneway, Oneway::Forward);
    assert!(road(&net, "8").attributes.bridge);
}

#[test]
fn geometry_in_enu_and_wgs84() {
    let net = small();
    // Way 1 runs 0.002 deg of longitude east along 60 N: 2 * 55.80 m
    // (R_N cos L * 0.001 deg = 6,394,209 m * 0.5 * 1.745e-5 = 55.80 m).
    let r = road(&net, "1");
    assert!((r.length_m - 111.60).abs() < 0.05, "{}", r.length_m);
    for s in &net.segments {
        let d = (s.b[0] - s.a[0]).hypot(s.b[1] - s.a[1]);
        assert!((d - s.length_m).abs() < 1e-9);
        assert!(s.length_m > 1e-3);
    }
    // Offsets along the road are cumulative.
    let segs: Vec<_> = net
        .segments
        .iter()
        .filter(|s| net.roads[s.road as usize].attributes.id == "1")
        .collect();
    assert_eq!(segs.len(), 2);
    assert!((segs[1].road_offset_m - segs[0].length_m).abs() < 1e-9);
}

#[test]
fn topology_table_and_directed_successors() {
    let net = small();
    let sec = |road_id: &str| {
        net.roads
            .iter()
            .find(|r| r.attributes.id == road_id)
            .unwrap()
            .sections[0]
    };
    let w2 = sec("2");
    // Way 2 (node 3 -> node 4): at node 3 meet way 1's second section, way 8 and way 13.
    let at_start = net.topology.connected_at(&net.model, w2, SectionEnd::Start);
    assert_eq!(at_start.len(), 3);
    let at_end = net.topology.connected_at(&net.model, w2, SectionEnd::End);
    assert_eq!(at_end, vec![sec("3")]);
    // After driving way 2 forward, the only way on is way 3 against its
    // digitisation (oneway=-1); way 2 itself cannot be driven back.
    let next = net.topology.successors(
        &net.model,
        DirectedSection {
            section: w2,
            forward: true,
        },
    );
    assert_eq!(
        next,
        vec![DirectedSection {
            section: sec("3"),
            forward: false
        }]
    );
    // Way 13 (one-way into node 3) cannot be entered at node 3.
    let node3 = net.sections[w2 as usize].start;
    assert!(net
        .topology
        .departures(&net.model, node3)
        .all(|d| d.section != sec("13")));
}

#[test]
fn components() {
    let net = small();
    // Main cluster (with the roundabout and way 13), the two parts of way 6,
    // ways 10, 11 and 12 alone: 6 weak components. Strongly: the main cluster,
    // node 50 alone (way 13 leaves it one-way), and the five two-way islands.
    assert_eq!(net.topology.weak_components, 6);
    assert_eq!(net.topology.strong_components, 7);
}

#[test]
fn defects_are_found_where_planted() {
    let net = small();
    let d = net.defects(1.0);
    let c = |k: &str| d.counts[k];
    assert_eq!(c("zero_length_segment"), 2);
    assert_eq!(c("duplicate_section"), 1); // way 7 repeats way 1 between nodes 1 and 2
    assert_eq!(c("unconnected_close_nodes"), 1); // nodes 31 and 32, 0.56 m apart
    assert_eq!(c("dead_end_near_road"), 2); // both of them, each near the other road
    assert_eq!(c("dead_end"), 9); // the extract-edge ends of way 6 are not counted
    assert_eq!(c("unreachable_section"), 6); // way 13, and every island
                                             // The near-node check honours its tolerance.
    assert_eq!(net.defects(0.5).counts["unconnected_close_nodes"], 0);
    let close = d
        .items
        .iter()
        .find(|x| x.kind == "unconnected_close_nodes")
        .unwrap();
    assert!((close.lat_lon[0] - 60.004).abs() < 1e-6);
}

#[test]
fn geojson_features() {
    let net = Network::load(&data("small.geojson"), &LoadOptions::default()).unwrap();
    assert_eq!(net.report.format, "geojson");
    assert_eq!(net.report.features_read, 7);
    assert_eq!(net.report.skipped.get("geometry_polygon"), Some(&1));
    assert_eq!(net.report.skipped.get("geometry_point"), Some(&1));
    assert_eq!(net.report.skipped.get("geometry_missing"), Some(&1));
    assert_eq!(net.report.skipped.get("not_drivable"), Some(&1));
    assert_eq!(net.roads.len(), 3);
    let ring = road(&net, "101");
    assert_eq!(ring.attributes.lanes, Some(2));
    assert_eq!(ring.attributes.oneway, Oneway::Forward);
    let b = road(&net, "b-2");
    assert!(b.attributes.tunnel);
    assert_eq!(b.attributes.maxspeed_kmh, Some(50.0));
    assert_eq!(road(&net, "feature-6").attributes.highway, "road");
    // Features meeting at shared coordinates are joined: 101 is split at
    // (24.001, 60.0) by b-2 and at (24.002, 60.0) by the untagged feature.
    assert_eq!(ring.sections.len(), 2);
    assert_eq!(b.sections.len(), 2);
    assert_eq!(net.topology.weak_components, 2);
}

#[test]
fn long_chains_do_not_overflow_the_stack() {
    // 200,000 two-way roads end to end (a 200 km chain, 1 m apart in latitude
    // steps of 1e-5 deg) then a one-way return: deep graphs must not recurse.
    use waymark::network::{model_from_polylines, TagSet};
    let n = 200_000;
    let lat = |i: usize| 50.0 + i as f64 * 1e-5;
    let mut roads: Vec<_> = (0..n)
        .map(|i| {
            (
                TagSet::default().attributes(format!("r{i}")),
                vec![vec![[lat(i), 10.0], [lat(i + 1), 10.0]]],
            )
        })
        .collect();
    let mut oneway = TagSet::default();
    oneway.set("oneway", "yes");
    roads.push((
        oneway.attributes("back".into()),
        vec![vec![
            [lat(n), 10.0],
            [lat(n), 10.001],
            [lat(0), 10.001],
            [lat(0), 10.0],
        ]],
    ));
    let model = model_from_polylines(roads).unwrap();
    let net = Network::from_model(model, None).unwrap();
    assert_eq!(net.topology.weak_components, 1);
    assert_eq!(net.topology.strong_components, 1);
}
