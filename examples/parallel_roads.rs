//! Finds roads that run parallel 15–40 m apart on a map (issue 12, point 6):
//! pairs of segments of different roads within 20° of parallel whose
//! midpoints are 15–40 m apart across them and that overlap along them,
//! summed per pair of roads. Prints the pairs with the longest parallel
//! length: the places where a matcher can pick the wrong road.
//!
//! `cargo run --release --example parallel_roads -- maps/helsinki.osm.pbf`

use std::collections::HashMap;
use waymark::network::Network;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let path = std::env::args()
        .nth(1)
        .unwrap_or("maps/helsinki.osm.pbf".into());
    let net = Network::load(std::path::Path::new(&path), &Default::default())?;
    let segs = &net.segments;
    let cell = 50.0;
    let key = |p: [f64; 2]| ((p[0] / cell).floor() as i64, (p[1] / cell).floor() as i64);
    let mut grid: HashMap<(i64, i64), Vec<usize>> = HashMap::new();
    for (i, s) in segs.iter().enumerate() {
        let m = [(s.a[0] + s.b[0]) / 2.0, (s.a[1] + s.b[1]) / 2.0];
        grid.entry(key(m)).or_default().push(i);
    }
    // (road i, road j) → (parallel length, sum of separation × length)
    let mut pairs: HashMap<(u32, u32), (f64, f64)> = HashMap::new();
    for s in segs.iter() {
        if s.length_m < 2.0 {
            continue;
        }
        let d = [
            (s.b[0] - s.a[0]) / s.length_m,
            (s.b[1] - s.a[1]) / s.length_m,
        ];
        let m = [(s.a[0] + s.b[0]) / 2.0, (s.a[1] + s.b[1]) / 2.0];
        let (kx, ky) = key(m);
        for dx in -1..=1 {
            for dy in -1..=1 {
                let Some(list) = grid.get(&(kx + dx, ky + dy)) else {
                    continue;
                };
                for &j in list {
                    let t = &segs[j];
                    if t.road <= s.road || t.length_m < 2.0 {
                        continue;
                    }
                    let e = [
                        (t.b[0] - t.a[0]) / t.length_m,
                        (t.b[1] - t.a[1]) / t.length_m,
                    ];
                    let cos = (d[0] * e[0] + d[1] * e[1]).abs();
                    if cos < 20f64.to_radians().cos() {
                        continue;
                    }
                    let n = [(t.a[0] + t.b[0]) / 2.0, (t.a[1] + t.b[1]) / 2.0];
                    let along = (n[0] - m[0]) * d[0] + (n[1] - m[1]) * d[1];
                    let across = ((n[0] - m[0]) * d[1] - (n[1] - m[1]) * d[0]).abs();
                    let overlap = 0.5 * (s.length_m + t.length_m) - along.abs();
                    if !(15.0..=40.0).contains(&across) || overlap <= 0.0 {
                        continue;
                    }
                    let len = overlap.min(s.length_m).min(t.length_m);
                    let e = pairs.entry((s.road, t.road)).or_default();
                    e.0 += len;
                    e.1 += across * len;
                }
            }
        }
    }
    let mut v: Vec<_> = pairs.into_iter().collect();
    v.sort_by(|a, b| b.1 .0.total_cmp(&a.1 .0));
    println!("road a | road b | parallel m | mean separation m | a: class, oneway, lanes | b: ... | a point (lat, lon)");
    for ((a, b), (len, sum)) in v.iter().take(25) {
        let ra = &net.roads[*a as usize].attributes;
        let rb = &net.roads[*b as usize].attributes;
        let sa = net.roads[*a as usize].sections[0];
        let seg = &segs[net.sections[sa as usize].first_segment as usize];
        println!(
            "{} {:?} | {} {:?} | {len:.0} | {:.1} | {} {:?} {:?} | {} {:?} {:?} | {:.5}, {:.5}",
            ra.id,
            ra.name,
            rb.id,
            rb.name,
            sum / len,
            ra.highway,
            ra.oneway,
            ra.lanes,
            rb.highway,
            rb.oneway,
            rb.lanes,
            seg.a_lat_lon[0],
            seg.a_lat_lon[1]
        );
    }
    Ok(())
}
