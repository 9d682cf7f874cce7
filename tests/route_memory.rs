//! The memory estimate of a map route's truth
//! (`scenario::route_truth_bytes`, which `scenario::check_route_memory`
//! holds against `MAX_ROUTE_TRUTH_BYTES` before the truth is built) against
//! what the build really allocates: this test binary's allocator counts
//! the bytes live on the heap, and the test takes their peak while
//! `TruthSource::on_network` routes the waypoints and builds the truth on
//! an already loaded map. One test in this file, so that no other test
//! allocates meanwhile.
//!
//! The estimate must hold the peak (it is the check's upper bound) and
//! exceed it by less than 10 %. Where its margin comes from (5–7 % on
//! these routes): it takes the lane path 5 % longer than the route, a turn
//! on the spot at every route vertex in both plans (a speed-profile node
//! and a hard point each), and an arc and its speed limit at every leg.
//! It is also checked not to depend on the IMU rate or the speed: the
//! same route at 10 Hz and 5 km/h allocates exactly the same peak.

use std::alloc::{GlobalAlloc, Layout, System};
use std::path::PathBuf;
use std::sync::atomic::{AtomicUsize, Ordering::Relaxed};
use std::sync::Arc;
use waymark::scenario::{route_truth_bytes, RouteCounts, RouteKind};
use waymark::{plan_route, Network, Scenario, TruthSource};

/// The system allocator, counting the bytes live and their peak.
struct Counting;

static LIVE: AtomicUsize = AtomicUsize::new(0);
static PEAK: AtomicUsize = AtomicUsize::new(0);

fn grew(bytes: usize) {
    let now = LIVE.fetch_add(bytes, Relaxed) + bytes;
    PEAK.fetch_max(now, Relaxed);
}

// SAFETY: every call is passed on to `System` unchanged; the counters are
// atomics, which do not allocate.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        grew(layout.size());
        System.alloc(layout)
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        grew(layout.size());
        System.alloc_zeroed(layout)
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        LIVE.fetch_sub(layout.size(), Relaxed);
        System.dealloc(ptr, layout)
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        // Counted as a new block beside the old one, as a moving realloc
        // holds both.
        grew(new_size);
        LIVE.fetch_sub(layout.size(), Relaxed);
        System.realloc(ptr, layout, new_size)
    }
}

#[global_allocator]
static ALLOCATOR: Counting = Counting;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The demo scenario (its map made absolute) with `waypoints` (or the
/// demo's own) and `replace` applied.
fn demo(dir: &std::path::Path, waypoints: Option<String>, replace: &[(&str, &str)]) -> Scenario {
    let mut text = std::fs::read_to_string(root().join("scenarios/demo.toml")).unwrap();
    let map = root().join("maps/helsinki.osm.pbf");
    text = text.replace("../maps/helsinki.osm.pbf", &map.display().to_string());
    if let Some(w) = waypoints {
        let demo_w = "waypoints = [[60.1660, 24.9380], [60.1770, 24.9510], [60.1660, 24.9380]]";
        assert!(text.contains(demo_w));
        text = text.replace(demo_w, &format!("waypoints = [{w}]"));
    }
    for (from, to) in replace {
        assert!(text.contains(from), "{from}");
        text = text.replace(from, to);
    }
    let path = dir.join("s.toml");
    std::fs::write(&path, text).unwrap();
    Scenario::load(&path).unwrap()
}

/// The estimate of `scn`'s route and the heap's peak above its level
/// before the truth is built (routing included), on the loaded `net`.
fn estimate_and_peak(scn: &Scenario, net: &Arc<Network>) -> (u64, u64) {
    let RouteKind::Map { waypoints, .. } = &scn.route else {
        panic!("a map route")
    };
    let route = plan_route(net, waypoints).unwrap();
    let estimate = route_truth_bytes(&RouteCounts::of(scn, &route));
    drop(route);
    let base = LIVE.load(Relaxed);
    PEAK.store(base, Relaxed);
    let truth = TruthSource::on_network(scn, Arc::clone(net)).unwrap();
    let peak = PEAK.load(Relaxed) - base;
    drop(truth);
    (estimate, peak as u64)
}

#[test]
fn the_route_memory_estimate_holds_the_truths_peak_allocation() {
    let dir = tempfile::tempdir().unwrap();
    let net = Arc::new(
        Network::load(&root().join("maps/helsinki.osm.pbf"), &Default::default()).unwrap(),
    );
    // The demo: 4.1 km there and back with a stop and a turn on the spot;
    // then 100 waypoints round the demo's blocks (90 km, 5,242 vertices).
    let blocks: Vec<&str> = (0..100)
        .map(|i| {
            if i % 2 == 0 {
                "[60.1660, 24.9380]"
            } else {
                "[60.1680, 24.9400]"
            }
        })
        .collect();
    let blocks = blocks.join(", ");
    for (name, waypoints) in [("demo", None), ("blocks", Some(blocks.clone()))] {
        let scn = demo(dir.path(), waypoints, &[]);
        let (estimate, peak) = estimate_and_peak(&scn, &net);
        let ratio = estimate as f64 / peak as f64;
        eprintln!("{name}: estimate {estimate} B, peak {peak} B, ratio {ratio:.3}");
        assert!(
            (1.0..1.10).contains(&ratio),
            "{name}: estimate {estimate} B against a peak of {peak} B"
        );
    }
    // Neither the IMU rate nor the speed changes what is allocated.
    let base = demo(dir.path(), Some(blocks.clone()), &[]);
    let (_, peak) = estimate_and_peak(&base, &net);
    let other = demo(
        dir.path(),
        Some(blocks),
        &[
            ("rate_hz = 100", "rate_hz = 10"),
            ("speed_kmh = 50", "speed_kmh = 5"),
        ],
    );
    assert!((other.dt - 0.1).abs() < 1e-12);
    assert_eq!(estimate_and_peak(&other, &net).1, peak);
}
