//! How far the simulated vehicle's path (the truth) strays from its route's
//! centre line: the distance of every truth sample from the route polyline
//! (`cargo run --release --example truth_offroad -- SCENARIO.toml...`).
use std::path::Path;
use waymark::geodesy::Geodetic;
use waymark::network::point_segment_distance;
use waymark::{Scenario, TruthSource};

fn main() {
    for arg in std::env::args().skip(1) {
        let scn = Scenario::load(Path::new(&arg)).expect("scenario");
        let truth = TruthSource::new(&scn).expect("truth");
        let (Some(route), Some(net)) = (truth.route(), truth.network()) else {
            println!("{arg}: not a map route");
            continue;
        };
        let v = &route.vertices;
        let mut d: Vec<f64> = Vec::new();
        let mut j = 0usize;
        let mut next = 0.0;
        for s in truth.samples() {
            if s.t < next {
                continue;
            }
            next += 1.0;
            let e = net.frame.to_enu(&Geodetic {
                lat: s.state.lat,
                lon: s.state.lon,
                height: 0.0,
            });
            let p = [e[0], e[1]];
            // Nearest over the vertices within ±300 m of chainage of the sample's distance.
            while j + 1 < v.len() && v[j + 1].chainage_m < s.distance_m - 300.0 {
                j += 1;
            }
            let mut best = f64::INFINITY;
            let mut k = j;
            while k + 1 < v.len() && v[k].chainage_m < s.distance_m + 300.0 {
                best = best.min(point_segment_distance(p, v[k].enu, v[k + 1].enu));
                k += 1;
            }
            d.push(best);
        }
        d.sort_by(f64::total_cmp);
        let q = |p: f64| d[((p * d.len() as f64) as usize).min(d.len() - 1)];
        let over = |x: f64| d.iter().filter(|&&y| y > x).count() as f64 / d.len() as f64;
        println!(
            "{arg}: {} samples (1 s): median {:.2} m, 95 % {:.2} m, 99 % {:.2} m, max {:.2} m; share > 2 m {:.3}, > 5 m {:.3}, > 10 m {:.3}",
            d.len(), q(0.5), q(0.95), q(0.99), d[d.len() - 1], over(2.0), over(5.0), over(10.0)
        );
    }
}
