//! Per-axis errors of a scenario's Monte Carlo runs (issue 12, points 5 and
//! 6): for each run the largest |east| (longitude) and |north| (latitude)
//! error and their RMS, then the median and 90th percentile over the runs,
//! and the map feed's counts: the figures the land-navigation paper gives
//! per axis (PAPERS.md §3.3), for scenarios run with and without map
//! matching.
//!
//! `cargo run --release --example axis_errors -- SCENARIO.toml [RUNS] [SEED]`

use waymark::sim::{simulate, Scenario, TruthSource};

fn pct(mut v: Vec<f64>, p: f64) -> f64 {
    v.sort_by(f64::total_cmp);
    v[((v.len() - 1) as f64 * p).round() as usize]
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let path = args
        .next()
        .ok_or("usage: axis_errors SCENARIO.toml [RUNS] [SEED]")?;
    let runs: u64 = args.next().map_or(Ok(100), |s| s.parse())?;
    let seed: u64 = args.next().map_or(Ok(1), |s| s.parse())?;
    let scn = Scenario::load(std::path::Path::new(&path))?;
    let truth = TruthSource::new(&scn)?;
    let r = simulate(&scn, &truth, runs, seed)?;
    let (mut me, mut mn, mut re, mut rn) = (vec![], vec![], vec![], vec![]);
    for run in &r.runs {
        let n = run.rows.len().max(1) as f64;
        me.push(run.rows.iter().map(|x| x.east_m.abs()).fold(0.0, f64::max));
        mn.push(run.rows.iter().map(|x| x.north_m.abs()).fold(0.0, f64::max));
        re.push((run.rows.iter().map(|x| x.east_m * x.east_m).sum::<f64>() / n).sqrt());
        rn.push((run.rows.iter().map(|x| x.north_m * x.north_m).sum::<f64>() / n).sqrt());
    }
    println!(
        "{path}: {runs} runs, seed {seed}\n\
         per-run max |east| median {:.1} m (p90 {:.1}), max |north| median {:.1} m (p90 {:.1})\n\
         per-run RMS east median {:.1} m, north {:.1} m\n\
         horizontal: max {:.1} m, p95 {:.1} m, RMS {:.1} m; NEES {:?}\n\
         map matching: {:?}",
        pct(me.clone(), 0.5),
        pct(me, 0.9),
        pct(mn.clone(), 0.5),
        pct(mn, 0.9),
        pct(re, 0.5),
        pct(rn, 0.5),
        r.summary.max_horizontal_error_m,
        r.summary.p95_horizontal_error_m,
        r.summary.rms_horizontal_error_m,
        r.summary
            .nees
            .as_ref()
            .map(|n| (n.mean, n.fraction_within_band)),
        r.summary.map_matching,
    );
    Ok(())
}
