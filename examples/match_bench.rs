//! Matching throughput on one track file: `match_rows` (the HMM with the
//! default options, the complete path included) run REPEATS times after the
//! map is loaded; prints points per second (BENCHMARKS.md, "Matching").
//!
//! Usage: cargo run --release --example match_bench -- MAP TRACK REPEATS

use std::time::Instant;
use waymark::matching::inputs::read_track_file;
use waymark::matching::options::MatchOptions;
use waymark::matching::track::match_rows;
use waymark::network::{LoadOptions, Network};

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    anyhow::ensure!(args.len() == 3, "usage: match_bench MAP TRACK REPEATS");
    let net = Network::load(std::path::Path::new(&args[0]), &LoadOptions::default())?;
    let (rows, _) = read_track_file(std::path::Path::new(&args[1]))?;
    let repeats: usize = args[2].parse()?;
    let opts = MatchOptions::default();
    let mut matched = 0;
    let t0 = Instant::now();
    for _ in 0..repeats {
        let (_, outcomes) = match_rows(&net, &rows, &opts);
        matched = outcomes.iter().map(|o| o.matched).sum::<usize>();
    }
    let s = t0.elapsed().as_secs_f64();
    println!(
        "{{\"points\":{},\"matched\":{matched},\"repeats\":{repeats},\"match_points_per_s\":{:.0}}}",
        rows.len(),
        (rows.len() * repeats) as f64 / s
    );
    Ok(())
}
