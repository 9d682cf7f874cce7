//! Dumps a map's directed sections and a track's fixes in the map's local
//! frame (metres) as JSON, so another matcher can run on exactly the same
//! network and points (BENCHMARKS.md, "Matching": the fastmm comparison).
//!
//! Usage: cargo run --release --example match_dump -- MAP TRACK OUT.json
//!
//! Beside the sections and the tracks it writes each track's search radius
//! and σ̂ as `waymark match` takes them from the track by default
//! (`"radius_m"`, `"sigma_hat_m"`), so the other matcher can be run at
//! Waymark's own radius (`fastmm_compare.py ... auto`).

use std::fmt::Write as _;
use waymark::matching::inputs::read_track_file;
use waymark::matching::options::{estimate_sigma_m, MatchOptions};
use waymark::matching::track::{group_tracks, to_fix};
use waymark::network::{LoadOptions, Network, Oneway};

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    anyhow::ensure!(args.len() == 3, "usage: match_dump MAP TRACK OUT.json");
    let net = Network::load(std::path::Path::new(&args[0]), &LoadOptions::default())?;
    let (rows, _) = read_track_file(std::path::Path::new(&args[1]))?;
    let mut s = String::from("{\"sections\":[");
    for (i, sec) in net.sections.iter().enumerate() {
        let mut pts = Vec::new();
        for seg in sec.segment_ids() {
            let g = &net.segments[seg as usize];
            if pts.is_empty() {
                pts.push(g.a);
            }
            pts.push(g.b);
        }
        let oneway = match sec.oneway {
            Oneway::Both => "both",
            Oneway::Forward => "forward",
            Oneway::Backward => "backward",
        };
        let _ = write!(
            s,
            "{}{{\"id\":{i},\"road\":{},\"start\":{},\"end\":{},\"oneway\":\"{oneway}\",\"enu\":{}}}",
            if i > 0 { "," } else { "" },
            serde_json::to_string(&net.roads[sec.road as usize].attributes.id)?,
            sec.start,
            sec.end,
            serde_json::to_string(&pts)?
        );
    }
    s.push_str("],\"tracks\":{");
    let mut radii = String::new();
    for (k, (id, idx)) in group_tracks(&rows).iter().enumerate() {
        let all: Vec<_> = idx.iter().map(|&i| to_fix(&net, &rows[i])).collect();
        let params = MatchOptions::default().hmm_params(&net, &all);
        let _ = write!(
            radii,
            "{}{}:{{\"radius_m\":{},\"sigma_hat_m\":{}}}",
            if k > 0 { "," } else { "" },
            serde_json::to_string(id)?,
            params.search_radius_m,
            estimate_sigma_m(&net, &all).map_or("null".to_string(), |v| v.to_string())
        );
        let fixes: Vec<[f64; 3]> = all.iter().map(|f| [f.enu[0], f.enu[1], f.t_s]).collect();
        let _ = write!(
            s,
            "{}{}:{}",
            if k > 0 { "," } else { "" },
            serde_json::to_string(id)?,
            serde_json::to_string(&fixes)?.replace("null", "NaN")
        );
    }
    s.push_str("},\"params\":{");
    s.push_str(&radii);
    s.push_str("}}");
    std::fs::write(&args[2], s)?;
    Ok(())
}
