//! The map-matching reach by the covariance engine's bound beside the
//! simulated error (`waymark::planner::network::simulated_reach`), per speed
//! class:
//!
//! `cargo run --release --example mc_reach -- SCENARIO.toml [RUNS] [KMH,KMH,...] [AFTER_M] [SEED]`
//!
//! Defaults: 60 runs, 5,10,20,30,40,50 km/h, roads running 12 km past
//! their reset, seed 1, at Helsinki (60.17° N, 24.94° E, 10 m: the reach
//! hardly depends on where). The requirement and its confidence are the
//! scenario's.
use std::path::Path;
use waymark::planner::network::{simulated_reach, CalibrationSite, ReachRequirement};
use waymark::Scenario;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some(path) = args.first() else {
        return Err("usage: mc_reach SCENARIO.toml [RUNS] [KMH,KMH,...] [AFTER_M] [SEED]".into());
    };
    let scn = Scenario::load(Path::new(path))?;
    let runs: u64 = args.get(1).map_or(Ok(60), |s| s.parse())?;
    let speeds: Vec<f64> = args
        .get(2)
        .map_or("5,10,20,30,40,50", |s| s.as_str())
        .split(',')
        .map(str::parse)
        .collect::<Result<_, _>>()?;
    let after_m: f64 = args.get(3).map_or(Ok(12_000.0), |s| s.parse())?;
    let seed: u64 = args.get(4).map_or(Ok(1), |s| s.parse())?;
    let req = scn
        .requirement_m()
        .ok_or("the scenario has no requirement_m")?;
    let conf = scn.planner().requirement_confidence;
    let site = CalibrationSite {
        lat_deg: 60.17,
        lon_deg: 24.94,
        height_m: 10.0,
    };
    let rq = ReachRequirement {
        req_m: req,
        p: conf,
    };
    println!(
        "{}: requirement {req} m at {conf}; {runs} runs per road, seed {seed}; \
         reach in m after the reset (bound / MC 95th percentile / its 95 % upper bound)",
        path
    );
    for kmh in speeds {
        let t = std::time::Instant::now();
        let r = simulated_reach(&scn, site, kmh / 3.6, rq, runs, seed, after_m)?;
        println!("{kmh} km/h ({:.0} s)", t.elapsed().as_secs_f64());
        for d in &r.drives {
            println!(
                "  {:<24} {:>7.0} {:>7.0} {:>7}{}",
                d.name,
                d.bound_reach_m,
                d.q95_reach_m,
                d.upper_reach_m.map_or("-".into(), |u| format!("{u:.0}")),
                if d.capped {
                    "  (road ended: at least)"
                } else {
                    ""
                }
            );
        }
    }
    Ok(())
}
