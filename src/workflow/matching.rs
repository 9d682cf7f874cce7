//! `waymark match`: a track file matched to a map, written as a CSV.

use super::inputs::{check_distinct_files, check_out_dir};
use crate::error::{Error, Result};
use crate::fsio::OutputSet;
use crate::matching::evaluate::{self, Score};
use crate::matching::inputs::{read_track_file, sniff_file, TrackFormat};
use crate::matching::options::MatchOptions;
use crate::matching::path_out;
use crate::matching::stream::match_csv_stream;
use crate::matching::track::{self as tr, Method};
use crate::matching::HmmParams;
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
    /// The track: CSV, GPX or GeoJSON (recognised by content).
    pub track: &'a Path,
    /// The matched CSV to write.
    pub out_file: &'a Path,
    /// The matcher, its search radius, noise and caps.
    pub options: MatchOptions,
    /// The roads actually driven (CSV), to score the complete path against.
    pub truth: Option<&'a Path>,
    /// The complete path's CSV to write.
    pub path: Option<&'a Path>,
    /// The complete path's GeoJSON to write.
    pub path_geojson: Option<&'a Path>,
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
    /// The HMM's probability model (`drift` or `independent`); absent for
    /// the incremental matcher.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub model: Option<&'static str>,
    /// The track file's format (`csv`, `gpx` or `geojson`).
    pub format: &'static str,
    /// Search radius and white-noise σ used (m), per track in file order
    /// (from the options, else from the track).
    pub radius_m: Vec<f64>,
    /// σ of the white part of the error model (m), per track.
    pub sigma_m: Vec<f64>,
    /// Continuous pieces of the complete path (all tracks).
    pub path_pieces: usize,
    /// Length of the complete path (m, all tracks).
    pub path_length_m: f64,
    /// The path files written.
    pub path_files: Vec<String>,
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
    /// Matching (the complete path included).
    pub r#match: f64,
}

/// The method's name.
fn method_name(m: Method) -> &'static str {
    match m {
        Method::Incremental => "incremental",
        Method::Hmm => "hmm",
    }
}

/// The HMM's model name, none for the incremental matcher.
fn model_name(o: &MatchOptions) -> Option<&'static str> {
    (o.method == Method::Hmm).then(|| o.model.as_str())
}

/// The output (given as `option`) and its folder are checked before any
/// work; the folder is made when writing.
fn check_out(file: &Path, option: &str) -> Result<()> {
    // `sub/..`, `p.csv/`: a folder's name, whatever is there now (after a
    // first output was written, it could not be written as a file).
    let text = file.as_os_str().as_encoded_bytes();
    if file.file_name().is_none() || text.ends_with(b"/") || text.ends_with(b"/.") {
        return Err(Error::format(
            file,
            format!("{option} names a folder, not a file; give a file name"),
        ));
    }
    if let Some(parent) = file.parent().filter(|p| !p.as_os_str().is_empty()) {
        check_out_dir(parent)?;
    }
    if file.is_dir() {
        return Err(Error::format(file, "the output file is an existing folder"));
    }
    Ok(())
}

/// The error of a track none of whose points lies near a road of the map
/// (the largest search radius of its tracks' parameters named).
fn nothing_matched<'p>(job: &MatchJob, params: impl Iterator<Item = &'p HmmParams>) -> Error {
    let radius = params.map(|p| p.search_radius_m).fold(0.0, f64::max);
    Error::format(
        job.track,
        format!(
            "no point lies within {radius:.0} m of a road of {} (is the track on this map?)",
            job.map.display()
        ),
    )
}

/// Adds the complete path's files asked for (`--path`, `--path-geojson`) to
/// `files`; their names.
fn write_paths(
    files: &mut OutputSet,
    job: &MatchJob,
    net: &Network,
    tracks: &[(&str, &[crate::matching::cpath::PathStep])],
) -> Result<Vec<String>> {
    let mut names = Vec::new();
    if let Some(f) = job.path {
        files.write(f, path_out::path_csv(net, tracks).as_bytes())?;
        names.push(f.display().to_string());
    }
    if let Some(f) = job.path_geojson {
        files.write(f, path_out::path_geojson(net, tracks).as_bytes())?;
        names.push(f.display().to_string());
    }
    Ok(names)
}

/// Matches the track file to the map and writes the matched CSV (and the
/// complete path, when asked); with a truth file, scores the complete path
/// by length and count.
pub fn match_file(job: &MatchJob) -> Result<MatchOutcome> {
    let t0 = Instant::now();
    job.options.validate()?;
    let outputs: Vec<(&Path, &str)> = [
        (Some(job.out_file), "--out"),
        (job.path, "--path"),
        (job.path_geojson, "--path-geojson"),
    ]
    .into_iter()
    .filter_map(|(p, o)| p.map(|p| (p, o)))
    .collect();
    for (f, option) in &outputs {
        check_out(f, option)?;
    }
    let inputs: Vec<(&Path, &str)> = [
        (Some(job.map), "--map"),
        (Some(job.track), "--track"),
        (job.truth, "--truth"),
    ]
    .into_iter()
    .filter_map(|(p, o)| p.map(|p| (p, o)))
    .collect();
    check_distinct_files(&outputs, &inputs)?;
    if sniff_file(job.track)? == TrackFormat::Csv {
        let net = Network::load(job.map, &LoadOptions::default())?;
        let truth = job
            .truth
            .map(|p| evaluate::read_truth(p, &net))
            .transpose()?;
        let load_ms = t0.elapsed().as_secs_f64() * 1e3;
        if let Some(o) = streamed(job, &net, truth, load_ms)? {
            return Ok(o);
        }
    }
    let (rows, format) = read_track_file(job.track)?;
    let net = Network::load(job.map, &LoadOptions::default())?;
    let truth = job
        .truth
        .map(|p| evaluate::read_truth(p, &net))
        .transpose()?;
    let load_ms = t0.elapsed().as_secs_f64() * 1e3;
    let t1 = Instant::now();
    let (points, outcomes) = tr::match_rows(&net, &rows, &job.options);
    let match_ms = t1.elapsed().as_secs_f64() * 1e3;
    let matched: usize = outcomes.iter().map(|o| o.matched).sum();
    if matched == 0 {
        return Err(nothing_matched(job, outcomes.iter().map(|o| &o.params)));
    }
    // All outputs or none: each is complete before any is renamed into place.
    let mut files = OutputSet::new();
    files.write(
        job.out_file,
        tr::matched_csv(&net, &rows, &points).as_bytes(),
    )?;
    let tracks: Vec<(&str, &[_])> = outcomes
        .iter()
        .map(|o| (o.track_id.as_str(), &o.path[..]))
        .collect();
    let path_files = write_paths(&mut files, job, &net, &tracks)?;
    files.commit()?;
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
    let paths: Vec<&[_]> = tracks.iter().map(|t| t.1).collect();
    let lengths = path_out::path_lengths(&net, &paths);
    let score = truth.map(|truth| evaluate::score(&lengths, &truth));
    let path_pieces = outcomes
        .iter()
        .map(|o| o.path.last().map_or(0, |p| p.piece as usize + 1))
        .sum();
    Ok(MatchOutcome {
        map: job.map.display().to_string(),
        track: job.track.display().to_string(),
        out: job.out_file.display().to_string(),
        method: method_name(job.options.method),
        model: model_name(&job.options),
        format: format.as_str(),
        radius_m: outcomes.iter().map(|o| o.params.search_radius_m).collect(),
        sigma_m: outcomes.iter().map(|o| o.params.sigma_m).collect(),
        path_pieces,
        path_length_m: lengths.values().sum::<f64>() + 0.0, // not -0 when empty
        path_files,
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

/// `match_file` on a CSV track, streamed (memory of the order of the
/// matcher's window): `None` when the file interleaves its tracks.
fn streamed(
    job: &MatchJob,
    net: &Network,
    truth: Option<evaluate::RoadLengths>,
    load_ms: f64,
) -> Result<Option<MatchOutcome>> {
    let t1 = Instant::now();
    let mut files = OutputSet::new();
    let mut file = files.create(job.out_file)?;
    let keep_path = job.path.is_some() || job.path_geojson.is_some();
    let Some(r) = match_csv_stream(
        net,
        job.track,
        &job.options,
        keep_path,
        &mut file,
        job.out_file,
    )?
    else {
        return Ok(None);
    };
    let match_ms = t1.elapsed().as_secs_f64() * 1e3;
    let matched: usize = r.tracks.iter().map(|t| t.matched).sum();
    if matched == 0 {
        return Err(nothing_matched(job, r.tracks.iter().map(|o| &o.params)));
    }
    files.add(file);
    let tracks: Vec<(&str, &[_])> = r
        .tracks
        .iter()
        .map(|o| (o.track_id.as_str(), &o.path[..]))
        .collect();
    let path_files = write_paths(&mut files, job, net, &tracks)?;
    files.commit()?;
    let mut breaks = Vec::new();
    let mut spans = Vec::new();
    let mut unmatched_tracks = Vec::new();
    for o in &r.tracks {
        if o.matched == 0 {
            unmatched_tracks.push(o.track_id.clone());
            continue;
        }
        for (b, line) in &o.breaks {
            breaks.push(MatchBreak {
                track_id: o.track_id.clone(),
                reason: b.reason.as_str(),
                before_t_s: b.before.map(|(_, t)| t),
                after_t_s: b.after.1,
                line: *line,
            });
        }
        for (lines, t_s, points) in &o.unmatched {
            spans.push(UnmatchedSpan {
                track_id: o.track_id.clone(),
                first_line: lines[0],
                last_line: lines[1],
                t_s: *t_s,
                points: *points,
            });
        }
    }
    let points: usize = r.tracks.iter().map(|t| t.points).sum();
    let score = truth.map(|truth| evaluate::score(&r.lengths, &truth));
    Ok(Some(MatchOutcome {
        map: job.map.display().to_string(),
        track: job.track.display().to_string(),
        out: job.out_file.display().to_string(),
        method: method_name(job.options.method),
        model: model_name(&job.options),
        format: TrackFormat::Csv.as_str(),
        radius_m: r.tracks.iter().map(|o| o.params.search_radius_m).collect(),
        sigma_m: r.tracks.iter().map(|o| o.params.sigma_m).collect(),
        path_pieces: r.tracks.iter().map(|o| o.pieces).sum(),
        path_length_m: r.lengths.values().sum::<f64>() + 0.0, // not -0 when empty
        path_files,
        points,
        tracks: r.tracks.len(),
        matched,
        matched_share: matched as f64 / points as f64,
        breaks,
        unmatched_spans: spans,
        score,
        timings_ms: Timings {
            load: load_ms,
            r#match: match_ms,
        },
        unmatched_tracks,
    }))
}
