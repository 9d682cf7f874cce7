//! The Hilbert grid and the R-tree answer the same queries with the same sets,
//! on the bundled real maps, for random points, radii and boxes, and for
//! several grid sizes (including degenerate N = 1 and a fine N = 1024).

use proptest::prelude::*;
use std::path::Path;
use std::sync::OnceLock;
use waymark::network::{GridIndex, LoadOptions, Network};

fn load(name: &str) -> Network {
    let p = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("maps")
        .join(name);
    Network::load(&p, &LoadOptions::default()).expect("bundled map loads")
}

fn gothenburg() -> &'static Network {
    static NET: OnceLock<Network> = OnceLock::new();
    NET.get_or_init(|| load("gothenburg-roads.geojson"))
}

fn helsinki() -> &'static Network {
    static NET: OnceLock<Network> = OnceLock::new();
    NET.get_or_init(|| load("helsinki.osm.pbf"))
}

fn helsinki_grids() -> &'static Vec<GridIndex> {
    static G: OnceLock<Vec<GridIndex>> = OnceLock::new();
    G.get_or_init(|| {
        let net = helsinki();
        [1, 2, 16, 1024]
            .iter()
            .map(|&n| GridIndex::build(&net.segments, net.bbox, Some(n)).unwrap())
            .collect()
    })
}

fn sorted(mut v: Vec<u32>) -> Vec<u32> {
    v.sort_unstable();
    v
}

/// A point in the map's box, extended by 10 % on each side so that queries
/// partly or wholly outside the map are exercised too.
fn point_in(net: &Network, fx: f64, fy: f64) -> [f64; 2] {
    let b = net.bbox;
    let (w, h) = (b[2] - b[0], b[3] - b[1]);
    [b[0] - 0.1 * w + 1.2 * w * fx, b[1] - 0.1 * h + 1.2 * h * fy]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2000))]

    #[test]
    fn radius_queries_agree_gothenburg(fx in 0.0f64..1.0, fy in 0.0f64..1.0, r in 0.0f64..400.0) {
        let net = gothenburg();
        let p = point_in(net, fx, fy);
        let grid = sorted(net.grid.within_radius(p, r));
        let tree = sorted(net.rtree.within_radius(p, r));
        prop_assert_eq!(&grid, &tree);
        // Each segment reported once.
        let mut dedup = grid.clone();
        dedup.dedup();
        prop_assert_eq!(dedup.len(), grid.len());
    }

    #[test]
    fn box_queries_agree_gothenburg(fx in 0.0f64..1.0, fy in 0.0f64..1.0, w in 0.0f64..2000.0, h in 0.0f64..2000.0) {
        let net = gothenburg();
        let p = point_in(net, fx, fy);
        let q = [p[0] + w, p[1] + h];
        prop_assert_eq!(sorted(net.grid.in_box(p, q)), sorted(net.rtree.in_box(p, q)));
    }

    #[test]
    fn queries_agree_for_every_grid_size(fx in 0.0f64..1.0, fy in 0.0f64..1.0, r in 0.0f64..300.0) {
        let net = helsinki();
        let p = point_in(net, fx, fy);
        let tree = sorted(net.rtree.within_radius(p, r));
        for g in helsinki_grids() {
            prop_assert_eq!(&sorted(g.within_radius(p, r)), &tree, "grid N={}", g.n());
        }
    }
}

#[test]
fn queries_find_something_on_real_roads() {
    // Guard against the property tests passing on empty answers: a query at
    // every segment's midpoint must find at least that segment.
    let net = gothenburg();
    for (i, s) in net.segments.iter().enumerate().step_by(97) {
        let m = [(s.a[0] + s.b[0]) / 2.0, (s.a[1] + s.b[1]) / 2.0];
        assert!(net.grid.within_radius(m, 0.01).contains(&(i as u32)));
    }
}

#[test]
fn grid_size_is_validated() {
    let net = helsinki();
    for bad in [0, 3, 4096] {
        assert!(GridIndex::build(&net.segments, net.bbox, Some(bad)).is_err());
    }
}

/// The automatic N: ~100 m cells on the bundled maps (the segment cap leaves
/// them alone), and at most eight cells per segment on a sparse map, so a
/// few roads far apart do not build a 2048 × 2048 grid.
#[test]
fn automatic_grid_size_follows_the_box_and_the_segments() {
    use waymark::network::{auto_grid_n, auto_grid_n_for, MAX_CELLS_PER_SEGMENT};
    for net in [helsinki(), gothenburg()] {
        assert_eq!(net.grid.n(), auto_grid_n(net.bbox));
        assert_eq!(
            auto_grid_n_for(net.bbox, net.segments.len()),
            auto_grid_n(net.bbox)
        );
    }
    // 1,000 km square: 2048 by the box alone.
    let wide = [0.0, 0.0, 1e6, 1e6];
    assert_eq!(auto_grid_n(wide), 2048);
    for (segments, n) in [(0, 2), (1, 2), (2, 4), (7, 4), (8, 8), (1000, 64)] {
        let got = auto_grid_n_for(wide, segments);
        assert_eq!(got, n, "{segments} segment(s)");
        let cells = (got as usize).pow(2);
        assert!(cells <= MAX_CELLS_PER_SEGMENT * segments.max(1));
        assert!(4 * cells > MAX_CELLS_PER_SEGMENT * segments.max(1));
    }
}
