//! `waymark match`: a track file matched to a map, written as a CSV.

use super::inputs::check_out_dir;
use crate::error::{Error, Result};
use crate::fsio::write_atomic;
use crate::matching::evaluate::{self, RoadLengths, Score};
use crate::matching::track::{self as tr, Method};
use crate::network::{LoadOptions, Network};
use serde::Serialize;
use std::path::Path;
use std::time::Instant;

/// The matcher.
pub type MatchMethod = Method;

/// What to match, against what, and where to write it.
#[derive(Debug, Clone, Copy)]
pub struct MatchJob<'a> {
    /// The map file.
    pub map: &'a Path,
    /// The track CSV.
    pub track: &'a Path,
    /// The matched CSV to write.
    pub out_file: &'a Path,
    /// The matcher.
    pub method: MatchMethod,
    /// The roads actually driven (CSV), to score the match against.
    pub truth: Option<&'a Path>,
}

/// A break in the matched path.
#[derive(Debug, Clone, Serialize)]
pub struct MatchBreak {
    /// Track.
    pub track_id: String,
    /// Why (`gap`, `off_road`, ...).
    pub reason: &'static str,
    /// Time of the last matched fix before it (s).
    pub before_t_s: Option<f64>,
    /// Time of the first fix after it (s).
    pub after_t_s: f64,
    /// Line of that fix in the track file.
    pub line: usize,
}

/// A run of points that matched no road.
#[derive(Debug, Clone, Serialize)]
pub struct UnmatchedSpan {
    /// Track.
    pub track_id: String,
    /// First line in the track file.
    pub first_line: usize,
    /// Last line.
    pub last_line: usize,
    /// First and last time (s).
    pub t_s: [f64; 2],
    /// Points in it.
    pub points: u64,
}

/// What `match_file` did.
#[derive(Debug, Clone, Serialize)]
pub struct MatchOutcome {
    /// The map.
    pub map: String,
    /// The track.
    pub track: String,
    /// The matched CSV written.
    pub out: String,
    /// The matcher (`hmm` or `incremental`).
    pub method: &'static str,
    /// Points in the track file.
    pub points: usize,
    /// Tracks in it.
    pub tracks: usize,
    /// Points matched.
    pub matched: usize,
    /// Share of points matched.
    pub matched_share: f64,
    /// Breaks, in file order.
    pub breaks: Vec<MatchBreak>,
    /// Unmatched spans, in file order.
    pub unmatched_spans: Vec<UnmatchedSpan>,
    /// The score against the truth (with a truth file).
    pub score: Option<Score>,
    /// Load and match times (ms).
    pub timings_ms: Timings,
    /// Tracks none of whose points matched.
    #[serde(skip)]
    pub unmatched_tracks: Vec<String>,
}

/// Load and match times (ms).
#[derive(Debug, Clone, Copy, Serialize)]
pub struct Timings {
    /// Reading the track, the map and the truth.
    pub load: f64,
    /// Matching.
    pub r#match: f64,
}

/// The method's name.
fn method_name(m: Method) -> &'static str {
    match m {
        Method::Incremental => "incremental",
        Method::Hmm => "hmm",
    }
}

/// Matches the track file to the map and writes the matched CSV; with a
/// truth file, scores the matched roads by length and count.
pub fn match_file(job: &MatchJob) -> Result<MatchOutcome> {
    let t0 = Instant::now();
    // The output's folder is checked before any work, made when writing.
    if let Some(parent) = job.out_file.parent().filter(|p| !p.as_os_str().is_empty()) {
        check_out_dir(parent)?;
    }
    if job.out_file.is_dir() {
        return Err(Error::format(
            job.out_file,
            "the output file is an existing folder",
        ));
    }
    let rows = tr::read_track(job.track)?;
    let net = Network::load(job.map, &LoadOptions::default())?;
    let truth = job
        .truth
        .map(|p| evaluate::read_truth(p, &net))
        .transpose()?;
    let load_ms = t0.elapsed().as_secs_f64() * 1e3;
    let t1 = Instant::now();
    let (points, outcomes) = tr::match_rows(&net, &rows, job.method);
    let match_ms = t1.elapsed().as_secs_f64() * 1e3;
    let matched: usize = outcomes.iter().map(|o| o.matched).sum();
    if matched == 0 {
        return Err(Error::format(
            job.track,
            format!(
                "no point lies within 50 m of a road of {} (is the track on this map?)",
                job.map.display()
            ),
        ));
    }
    if let Some(parent) = job.out_file.parent().filter(|p| !p.as_os_str().is_empty()) {
        std::fs::create_dir_all(parent).map_err(|e| Error::io(parent, e))?;
    }
    write_atomic(
        job.out_file,
        tr::matched_csv(&net, &rows, &points).as_bytes(),
    )?;
    let mut breaks = Vec::new();
    let mut spans = Vec::new();
    let mut unmatched_tracks = Vec::new();
    for o in &outcomes {
        if o.matched == 0 {
            unmatched_tracks.push(o.track_id.clone());
            continue;
        }
        for b in &o.breaks {
            breaks.push(MatchBreak {
                track_id: o.track_id.clone(),
                reason: b.reason.as_str(),
                before_t_s: b.before.map(|(_, t)| t),
                after_t_s: b.after.1,
                line: rows[o.rows[b.after.0 as usize]].line,
            });
        }
        for sp in &o.unmatched {
            spans.push(UnmatchedSpan {
                track_id: o.track_id.clone(),
                first_line: rows[o.rows[sp.first as usize]].line,
                last_line: rows[o.rows[sp.last as usize]].line,
                t_s: sp.t_s,
                points: sp.last - sp.first + 1,
            });
        }
    }
    let score = truth.map(|truth| {
        let mut lengths = RoadLengths::new();
        for o in &outcomes {
            let pts: Vec<_> = o.rows.iter().map(|&i| points[i]).collect();
            for (k, v) in evaluate::matched_lengths(&net, &pts) {
                *lengths.entry(k).or_default() += v;
            }
        }
        evaluate::score(&lengths, &truth)
    });
    Ok(MatchOutcome {
        map: job.map.display().to_string(),
        track: job.track.display().to_string(),
        out: job.out_file.display().to_string(),
        method: method_name(job.method),
        points: rows.len(),
        tracks: outcomes.len(),
        matched,
        matched_share: matched as f64 / rows.len() as f64,
        breaks,
        unmatched_spans: spans,
        score,
        timings_ms: Timings {
            load: load_ms,
            r#match: match_ms,
        },
        unmatched_tracks,
    })
}
