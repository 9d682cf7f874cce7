//! The map-matching reach by the covariance engine's bound beside the
//! simulated error (`waymark::planner::network::simulated_reach`), per speed
//! class:
//!
//! `cargo run --release --example mc_reach -- SCENARIO.toml [RUNS] [KMH,KMH,...] [AFTER_M] [SEED] [--cap M] [--legs K,K,...] [--straight L,L,...] [--grid LEGS:LEG_M,...]`
//!
//! Defaults: 60 runs, 5,10,20,30,40,50 km/h, roads running 12 km past
//! their reset, seed 1, at Helsinki (60.17° N, 24.94° E, 10 m: the reach
//! hardly depends on where). The requirement and its confidence are the
//! scenario's.
//!
//! * `--cap M`: stop the runs M m past each reset (`RoadRuns::capped_at`;
//!   a figure beyond it is printed as "≥ M").
//! * `--legs K,…`: instead of the five roads, the weak turn after K warm-up
//!   legs (`TurnLead::WarmUp`; 0: the first-turn road, 6: the calibrated
//!   turn), sharp and curve.
//! * `--straight L,…`: the weak turn after a straight of L m from the
//!   prior (`TurnLead::Straight`), sharp and curve.
//! * `--grid LEGS:LEG_M,…`: the weak turn after LEGS legs of LEG_M m
//!   alternating north and east, the last run on to 3 km in all if they
//!   are shorter (`TurnLead::Legs`), sharp and curve.
//!
//! With `--legs`, `--straight` or `--grid` each lead prints its two roads and the
//! weaker (the shorter reach by the upper bound, else the 95th percentile).
use std::path::Path;
use waymark::planner::network::{
    simulated_reach, turn_reach, CalibrationSite, ReachRequirement, RoadRuns, SimulatedDrive,
    TurnLead,
};
use waymark::Scenario;

const USAGE: &str = "usage: mc_reach SCENARIO.toml [RUNS] [KMH,KMH,...] [AFTER_M] [SEED] \
                     [--cap M] [--legs K,K,...] [--straight L,L,...] [--grid LEGS:LEG_M,...]";

fn list<T: std::str::FromStr>(s: &str) -> Result<Vec<T>, T::Err> {
    s.split(',').map(str::parse).collect()
}

fn row(d: &SimulatedDrive) -> String {
    format!(
        "  {:<24} {:>7.0} {:>7.0} {:>7}{}",
        d.name,
        d.bound_reach_m,
        d.q95_reach_m,
        d.upper_reach_m.map_or("-".into(), |u| format!("{u:.0}")),
        if d.capped {
            "  (road ended or capped: at least)"
        } else {
            ""
        }
    )
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args: Vec<String> = Vec::new();
    let (mut cap, mut leads) = (None::<f64>, Vec::<TurnLead>::new());
    let mut it = std::env::args().skip(1);
    while let Some(a) = it.next() {
        let mut val = || it.next().ok_or(USAGE);
        match a.as_str() {
            "--cap" => cap = Some(val()?.parse()?),
            "--legs" => leads.extend(list::<usize>(&val()?)?.into_iter().map(TurnLead::WarmUp)),
            "--straight" => leads.extend(list::<f64>(&val()?)?.into_iter().map(TurnLead::Straight)),
            "--grid" => {
                for g in val()?.split(',') {
                    let (legs, leg_m) = g.split_once(':').ok_or(USAGE)?;
                    leads.push(TurnLead::Legs {
                        legs: legs.parse()?,
                        leg_m: leg_m.parse()?,
                    });
                }
            }
            _ => args.push(a),
        }
    }
    let Some(path) = args.first() else {
        return Err(USAGE.into());
    };
    let scn = Scenario::load(Path::new(path))?;
    let runs: u64 = args.get(1).map_or(Ok(60), |s| s.parse())?;
    let speeds: Vec<f64> = list(args.get(2).map_or("5,10,20,30,40,50", |s| s.as_str()))?;
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
    let mut mc = RoadRuns::new(runs, seed, after_m);
    if let Some(c) = cap {
        mc = mc.capped_at(c);
    }
    println!(
        "{}: requirement {req} m at {conf}; {runs} runs per road, seed {seed}{}; \
         reach in m after the reset (bound / MC 95th percentile / its 95 % upper bound)",
        path,
        cap.map_or(String::new(), |c| format!(
            ", runs stopped {c} m past the reset"
        ))
    );
    for kmh in speeds {
        let t = std::time::Instant::now();
        if leads.is_empty() {
            let r = simulated_reach(&scn, site, kmh / 3.6, rq, &mc)?;
            println!("{kmh} km/h ({:.0} s)", t.elapsed().as_secs_f64());
            for d in &r.drives {
                println!("{}", row(d));
            }
            continue;
        }
        println!("{kmh} km/h");
        for &lead in &leads {
            let t = std::time::Instant::now();
            let [s, c] = turn_reach(&scn, site, kmh / 3.6, rq, &mc, lead)?;
            let key = |d: &SimulatedDrive| d.upper_reach_m.unwrap_or(d.q95_reach_m);
            let weaker = if key(&c) <= key(&s) { "curve" } else { "sharp" };
            println!("{}", row(&s));
            println!("{}", row(&c));
            println!(
                "    weaker: {weaker} ({:.0} s, {kmh} km/h)",
                t.elapsed().as_secs_f64()
            );
        }
        println!("{kmh} km/h ({:.0} s)", t.elapsed().as_secs_f64());
    }
    Ok(())
}
