//! Matching throughput on one track file: `FileMatcher::match_rows_into` (the
//! HMM with the default options, the complete path included) run REPEATS
//! times after the map is loaded, by one matcher kept across the repeats (as
//! a peer's matcher object is), into one output kept across them too (its
//! memory reused, as a server's would be), with its cache of network searches emptied
//! before each repeat (cold) or kept between repeats (warm); prints points
//! per second (BENCHMARKS.md, "Matching").
//!
//! Usage: cargo run --release --example match_bench -- MAP TRACK REPEATS [RADIUS_M|-] [warm] [independent] [fresh]
//! (RADIUS_M: `--radius-m`, e.g. a peer's search radius, instead of the
//! radius taken from the track; `-`: from the track. `warm`: only the warm
//! repeats, the first of them filling the cache, for counting the warm
//! repeats' instructions alone under callgrind: a run of REPEATS + 1 minus
//! one of 1. `independent`: `match --model independent`. `fresh`: a new
//! output for each repeat, `FileMatcher::match_rows`, as before the eighth
//! round).

use std::time::Instant;
use waymark::matching::inputs::read_track_file;
use waymark::matching::options::MatchOptions;
use waymark::matching::track::{FileMatch, FileMatcher};
use waymark::network::{LoadOptions, Network};

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let flags = args.get(4..).unwrap_or_default();
    anyhow::ensure!(
        args.len() >= 3
            && flags
                .iter()
                .all(|f| f == "warm" || f == "independent" || f == "fresh")
            && flags.len() <= 3,
        "usage: match_bench MAP TRACK REPEATS [RADIUS_M|-] [warm] [independent] [fresh]"
    );
    let fresh = flags.iter().any(|f| f == "fresh");
    let warm_only = flags.iter().any(|f| f == "warm");
    let model = if flags.iter().any(|f| f == "independent") {
        waymark::matching::HmmModel::Independent
    } else {
        waymark::matching::HmmModel::Drift
    };
    let net = Network::load(std::path::Path::new(&args[0]), &LoadOptions::default())?;
    let (rows, _) = read_track_file(std::path::Path::new(&args[1]))?;
    let repeats: usize = args[2].parse()?;
    let opts = MatchOptions {
        radius_m: args
            .get(3)
            .filter(|r| *r != "-")
            .map(|r| r.parse())
            .transpose()?,
        model,
        ..MatchOptions::default()
    };
    opts.validate()?;
    let mut matched = usize::MAX;
    // Cold: each repeat starts an empty cache of network searches (as
    // `waymark match` does for its one file).
    let mut matcher = FileMatcher::new(&net);
    let mut out = FileMatch::default();
    let t0 = Instant::now();
    for _ in 0..if warm_only { 0 } else { repeats } {
        matcher.forget_searches();
        if fresh {
            out.tracks = matcher.match_rows(&rows, &opts).1;
        } else {
            matcher.match_rows_into(&rows, &opts, &mut out);
        }
        matched = out.tracks.iter().map(|o| o.matched).sum::<usize>();
    }
    let cold = t0.elapsed().as_secs_f64();
    // Warm: the cache kept between repeats (as fastmm's UBODT, built once
    // before its matching is timed).
    matcher.forget_searches();
    let t0 = Instant::now();
    for _ in 0..repeats {
        if fresh {
            out.tracks = matcher.match_rows(&rows, &opts).1;
        } else {
            matcher.match_rows_into(&rows, &opts, &mut out);
        }
        matched = matched.min(out.tracks.iter().map(|o| o.matched).sum::<usize>());
    }
    let warm = t0.elapsed().as_secs_f64();
    println!(
        "{{\"points\":{},\"matched\":{matched},\"repeats\":{repeats},\"match_points_per_s\":{:.0},\"warm_match_points_per_s\":{:.0}}}",
        rows.len(),
        if warm_only {
            0.0
        } else {
            (rows.len() * repeats) as f64 / cold
        },
        (rows.len() * repeats) as f64 / warm
    );
    Ok(())
}
