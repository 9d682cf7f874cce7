//! TRACK.csv input and MATCHED.csv output (DESIGN.md).
//!
//! TRACK.csv: a header row naming at least `t_s`, `lat`, `lon`, optionally
//! `heading_deg` (clockwise from north), `speed_mps` and `track_id`, in any
//! order; rows in time order within each track, times within
//! ±[`MAX_ABS_TIME_S`]. Every problem is reported with the file and line.

use super::{Fix, MatchedPoint};
use crate::decimal::{push_display, push_fixed};
use crate::error::{Error, Result};
use crate::geodesy::Geodetic;
use crate::network::Network;
use rustc_hash::FxHashMap;
use std::fmt::Write as _;
use std::path::Path;

/// One row of TRACK.csv.
#[derive(Debug, Clone, PartialEq)]
pub struct TrackRow {
    /// 1-based line number in the file (GPX, GeoJSON: the point's number
    /// in the file).
    pub line: usize,
    /// Track identifier (empty when the file has no `track_id` column).
    pub track_id: String,
    /// Time (s); NaN where the file gives none (GPX, GeoJSON).
    pub t_s: f64,
    /// Latitude (degrees).
    pub lat: f64,
    /// Longitude (degrees).
    pub lon: f64,
    /// Heading (degrees clockwise from north), if given.
    pub heading_deg: Option<f64>,
    /// Speed (m/s), if given.
    pub speed_mps: Option<f64>,
}

/// A CSV table being read: the header and the data records after it, each
/// with its 1-based line number. Fields are trimmed; blank lines are skipped;
/// fields may be double-quoted (`""` is a quote inside a quoted field).
pub(crate) struct CsvTable<'a> {
    /// Line of the header row.
    pub header_line: usize,
    /// The header row as written in the file.
    pub header_text: &'a str,
    /// Column names, in order.
    pub names: Vec<String>,
    text: &'a str,
    reader: csv::Reader<&'a [u8]>,
    /// The record as read, and its fields trimmed (what callers see). The
    /// csv crate's own trimming (`Trim::All`) makes two new records per
    /// record read (its byte and string trims allocate); trimming here
    /// into a record kept across reads gives the same fields (`str::trim`:
    /// the Unicode whitespace csv's string trim removes, which includes
    /// the ASCII whitespace of its byte trim) without allocating.
    raw: csv::StringRecord,
    record: csv::StringRecord,
    /// Lines of the file before `text` (a chunk of a streamed file).
    line_offset: usize,
}

/// The largest track file read whole (GPX, GeoJSON, a CSV interleaving its
/// tracks), and the largest truth file: bytes. A CSV of contiguous tracks
/// is streamed without a limit.
pub const WHOLE_FILE_LIMIT_BYTES: u64 = 512 << 20;

/// The largest time a track may give, either side of zero (s): about 3,169
/// years, so a Unix time from 1199 BC to AD 5138 or a time from a
/// track's start. Beyond it a time is a mistake (`1e300`, a time in
/// milliseconds or nanoseconds since the epoch), whose gaps and speeds the
/// matcher would take as they were.
pub const MAX_ABS_TIME_S: f64 = 1e11;

/// The message for a time beyond [`MAX_ABS_TIME_S`] (`what`: how the file
/// names it, with its value).
pub(crate) fn time_beyond_limit(what: &str) -> String {
    format!(
        "{what} is beyond the limit of ±1e11 s (3,169 years; a Unix time in seconds is \
         about 1.7e9 now: a time in milliseconds or nanoseconds?)"
    )
}

/// Reads a file as UTF-8 text without a byte-order mark.
pub(crate) fn read_text(path: &Path, what: &str) -> Result<String> {
    // Limited like a track read whole: an endless input (`/dev/zero`) or a
    // huge file is refused, not read until memory runs out.
    let bytes = crate::fsio::read_limited(path, WHOLE_FILE_LIMIT_BYTES, what)?;
    let mut text = String::from_utf8(bytes).map_err(|e| {
        let at = e.utf8_error().valid_up_to();
        let line = 1 + e.as_bytes()[..at].iter().filter(|&&b| b == b'\n').count();
        Error::table(path, line, format!("not UTF-8 text ({})", e.utf8_error()))
    })?;
    if text.starts_with('\u{feff}') {
        text.drain(..'\u{feff}'.len_utf8());
    }
    Ok(text)
}

impl<'a> CsvTable<'a> {
    /// Starts reading `text` (the contents of `path`); `None` when it has no
    /// header row (no non-blank line).
    pub(crate) fn open(path: &Path, text: &'a str) -> Result<Option<CsvTable<'a>>> {
        let reader = csv::ReaderBuilder::new()
            .has_headers(false)
            .flexible(true)
            .from_reader(text.as_bytes());
        let mut t = CsvTable {
            header_line: 0,
            header_text: "",
            names: Vec::new(),
            text,
            reader,
            raw: csv::StringRecord::new(),
            record: csv::StringRecord::new(),
            line_offset: 0,
        };
        let Some((line, start)) = t.advance(path)? else {
            return Ok(None);
        };
        t.header_line = line;
        t.header_text = text[start..]
            .lines()
            .next()
            .unwrap_or_default()
            .trim_end_matches('\r');
        t.names = t.record.iter().map(str::to_owned).collect();
        Ok(Some(t))
    }

    /// Continues a table whose header was read: the data records of `text`,
    /// the part of the file after its first `line_offset` lines.
    pub(crate) fn continued(text: &'a str, names: Vec<String>, line_offset: usize) -> Self {
        let reader = csv::ReaderBuilder::new()
            .has_headers(false)
            .flexible(true)
            .from_reader(text.as_bytes());
        CsvTable {
            header_line: 0,
            header_text: "",
            names,
            text,
            reader,
            raw: csv::StringRecord::new(),
            record: csv::StringRecord::new(),
            line_offset,
        }
    }

    /// Reads the next non-blank record; its line number and the byte offset
    /// where it starts, or `None` at the end.
    fn advance(&mut self, path: &Path) -> Result<Option<(usize, usize)>> {
        loop {
            let more = self.reader.read_record(&mut self.raw).map_err(|e| {
                let line = e.position().map_or(0, |p| p.line() as usize) + self.line_offset;
                Error::table(path, line, format!("not readable as CSV ({e})"))
            })?;
            if !more {
                return Ok(None);
            }
            // The record's position is where the previous one ended: skip
            // the line ends (and empty lines) before its first byte.
            let (mut line, mut start) = self
                .raw
                .position()
                .map_or((1, 0), |p| (p.line() as usize, p.byte() as usize));
            for &b in &self.text.as_bytes()[start..] {
                match b {
                    b'\n' => line += 1,
                    b'\r' => {}
                    _ => break,
                }
                start += 1;
            }
            // A line of blanks reads as one empty field: skip it (but not `""`).
            if self.raw.len() == 1
                && self.raw[0].trim().is_empty()
                && self.text[start..]
                    .split('\n')
                    .next()
                    .is_some_and(|l| l.trim().is_empty())
            {
                continue;
            }
            self.record.clear();
            for field in &self.raw {
                self.record.push_field(field.trim());
            }
            return Ok(Some((line + self.line_offset, start)));
        }
    }

    /// The next data record with its line number, or `None` at the end.
    /// Errors when it has a different number of fields than the header.
    pub(crate) fn next_record(
        &mut self,
        path: &Path,
    ) -> Result<Option<(usize, &csv::StringRecord)>> {
        let Some((line, _)) = self.advance(path)? else {
            return Ok(None);
        };
        if self.record.len() != self.names.len() {
            return Err(Error::table(
                path,
                line,
                format!(
                    "{} fields, the header has {}",
                    self.record.len(),
                    self.names.len()
                ),
            ));
        }
        Ok(Some((line, &self.record)))
    }
}

fn number(path: &Path, line: usize, name: &str, v: &str) -> Result<f64> {
    let x: f64 = v
        .parse()
        .map_err(|_| Error::table(path, line, format!("{name} '{v}' is not a number")))?;
    if !x.is_finite() {
        return Err(Error::table(
            path,
            line,
            format!("{name} is {v}, not a finite number"),
        ));
    }
    Ok(x)
}

/// Reads and checks TRACK.csv.
pub fn read_track(path: &Path) -> Result<Vec<TrackRow>> {
    let text = read_text(path, "track")?;
    read_track_text(path, &text)
}

/// Checks TRACK.csv's text (the contents of `path`).
pub(crate) fn read_track_text(path: &Path, text: &str) -> Result<Vec<TrackRow>> {
    let Some(mut table) = CsvTable::open(path, text)? else {
        return Err(Error::table(
            path,
            1,
            "empty file: expected a header row t_s,lat,lon",
        ));
    };
    let cols = columns(path, &table)?;
    let hline = table.header_line;
    let mut rows = Vec::with_capacity(text.len() / 32); // a guess: rows are ~30 bytes
    let mut last_t: FxHashMap<String, (f64, usize)> = FxHashMap::default();
    while let Some((line, f)) = table.next_record(path)? {
        rows.push(parse_row(path, line, f, &cols, &mut last_t)?);
    }
    if rows.is_empty() {
        return Err(Error::table(path, hline, "no data rows after the header"));
    }
    Ok(rows)
}

/// The columns of TRACK.csv: t_s, lat, lon, heading_deg, speed_mps, track_id.
pub(crate) struct Columns([Option<usize>; 6]);

/// Finds TRACK.csv's columns in a table's header.
pub(crate) fn columns(path: &Path, table: &CsvTable) -> Result<Columns> {
    let col = |n: &str| table.names.iter().position(|h| h == n);
    let (Some(ct), Some(clat), Some(clon)) = (col("t_s"), col("lat"), col("lon")) else {
        let missing: Vec<&str> = ["t_s", "lat", "lon"]
            .into_iter()
            .filter(|n| col(n).is_none())
            .collect();
        return Err(Error::table(
            path,
            table.header_line,
            format!(
                "missing column(s) {} (header: '{}'; expected t_s,lat,lon[,heading_deg,speed_mps,track_id])",
                missing.join(", "),
                table.header_text
            ),
        ));
    };
    Ok(Columns([
        Some(ct),
        Some(clat),
        Some(clon),
        col("heading_deg"),
        col("speed_mps"),
        col("track_id"),
    ]))
}

/// Checks one data record of TRACK.csv (`last_t`: each track's last time
/// and line, for the time-order check).
pub(crate) fn parse_row(
    path: &Path,
    line: usize,
    f: &csv::StringRecord,
    cols: &Columns,
    last_t: &mut FxHashMap<String, (f64, usize)>,
) -> Result<TrackRow> {
    let [Some(ct), Some(clat), Some(clon), ch, cs, cid] = cols.0 else {
        unreachable!("columns() finds t_s, lat and lon")
    };
    let t_s = number(path, line, "t_s", &f[ct])?;
    if t_s.abs() > MAX_ABS_TIME_S {
        return Err(Error::table(
            path,
            line,
            time_beyond_limit(&format!("t_s {}", &f[ct])),
        ));
    }
    let lat = number(path, line, "lat", &f[clat])?;
    let lon = number(path, line, "lon", &f[clon])?;
    if !(-90.0..=90.0).contains(&lat) || !(-180.0..=180.0).contains(&lon) {
        return Err(Error::table(
            path,
            line,
            format!("coordinate out of range (lat {lat}, lon {lon})"),
        ));
    }
    let opt = |c: Option<usize>, name: &str| -> Result<Option<f64>> {
        match c {
            Some(c) if !f[c].is_empty() => number(path, line, name, &f[c]).map(Some),
            _ => Ok(None),
        }
    };
    let heading_deg = opt(ch, "heading_deg")?;
    let speed_mps = opt(cs, "speed_mps")?;
    let track_id = cid.map(|c| f[c].to_owned()).unwrap_or_default();
    match last_t.get_mut(&track_id) {
        Some((prev, pline)) => {
            if t_s < *prev {
                return Err(Error::table(
                    path,
                    line,
                    format!(
                        "not in time order: t_s {t_s} is earlier than {prev} on line {pline}{}",
                        if track_id.is_empty() {
                            String::new()
                        } else {
                            format!(" (track '{track_id}')")
                        }
                    ),
                ));
            }
            (*prev, *pline) = (t_s, line);
        }
        None => {
            last_t.insert(track_id.clone(), (t_s, line));
        }
    }
    Ok(TrackRow {
        line,
        track_id,
        t_s,
        lat,
        lon,
        heading_deg,
        speed_mps,
    })
}

/// Row indices of each track, in order of first appearance.
pub fn group_tracks(rows: &[TrackRow]) -> Vec<(String, Vec<usize>)> {
    let mut order: Vec<(String, Vec<usize>)> = Vec::new();
    let mut at: FxHashMap<&str, usize> = FxHashMap::default();
    // The group of the previous row, whose id the next row most often
    // shares (tracks come in runs): no hashing then.
    let mut last: Option<(&str, usize)> = None;
    for (i, r) in rows.iter().enumerate() {
        let id = r.track_id.as_str();
        let k = match last {
            Some((l, k)) if l == id => k,
            _ => {
                let k = *at.entry(id).or_insert_with(|| {
                    order.push((r.track_id.clone(), Vec::new()));
                    order.len() - 1
                });
                // Room for the whole run of rows of this track at once.
                let run = rows[i..].iter().take_while(|q| q.track_id == id).count();
                order[k].1.reserve(run);
                k
            }
        };
        last = Some((id, k));
        order[k].1.push(i);
    }
    order
}

/// A row as a fix in the network's frame.
pub fn to_fix(net: &Network, r: &TrackRow) -> Fix {
    let e = net.frame.to_enu(&Geodetic::from_degrees(r.lat, r.lon, 0.0));
    Fix {
        t_s: r.t_s,
        enu: [e[0], e[1]],
        heading_rad: r.heading_deg.map(f64::to_radians),
    }
}

/// Latitude and longitude of a matched point (interpolated between the
/// segment's WGS-84 vertices).
pub fn matched_lat_lon(net: &Network, m: &MatchedPoint) -> Option<[f64; 2]> {
    let seg = &net.segments[m.segment? as usize];
    let t = if seg.length_m > 0.0 {
        ((m.road_offset_m - seg.road_offset_m) / seg.length_m).clamp(0.0, 1.0)
    } else {
        0.0
    };
    Some([
        seg.a_lat_lon[0] + t * (seg.b_lat_lon[0] - seg.a_lat_lon[0]),
        seg.a_lat_lon[1] + t * (seg.b_lat_lon[1] - seg.a_lat_lon[1]),
    ])
}

/// Appends `field` as a CSV field: quoted (inner quotes doubled) when it
/// holds a comma, a quote or a line break; as it is otherwise.
pub(crate) fn push_csv_field(s: &mut String, field: &str) {
    if field.contains([',', '"', '\n']) {
        s.push('"');
        s.push_str(&field.replace('"', "\"\""));
        s.push('"');
    } else {
        s.push_str(field);
    }
}

/// The header of MATCHED.csv.
pub const MATCHED_HEADER: &str =
    "track_id,t_s,lat,lon,road_id,offset_m,distance_m,state,confidence\n";

/// Appends MATCHED.csv's row for input row `r` matched as `m`. The fixed
/// decimals are written by [`push_fixed`] (the same text as `{:.7}` and
/// the like, without core's formatting machinery: a third of a long
/// track's instructions before).
pub fn matched_row(s: &mut String, net: &Network, r: &TrackRow, m: &MatchedPoint) {
    push_csv_field(s, &r.track_id);
    s.push(',');
    if r.t_s.is_finite() {
        push_display(s, r.t_s);
    }
    s.push(',');
    match matched_lat_lon(net, m) {
        Some([lat, lon]) => {
            let road = &net.roads[m.road.unwrap_or(0) as usize].attributes.id;
            push_fixed(s, lat, 7);
            s.push(',');
            push_fixed(s, lon, 7);
            s.push(',');
            push_csv_field(s, road);
            s.push(',');
            push_fixed(s, m.road_offset_m, 2);
            s.push(',');
            push_fixed(s, m.distance_m, 2);
            s.push(',');
            s.push_str(m.state.as_str());
            s.push(',');
            push_fixed(s, m.confidence, 3);
            s.push('\n');
        }
        None => {
            let _ = writeln!(s, ",,,,,{},0", m.state.as_str());
        }
    }
}

/// MATCHED.csv text: one row per input row, in input order. `matched[i]` is
/// the match of `rows[i]`.
pub fn matched_csv(net: &Network, rows: &[TrackRow], matched: &[MatchedPoint]) -> String {
    let mut s = String::with_capacity(rows.len() * 96);
    s.push_str(MATCHED_HEADER);
    for (r, m) in rows.iter().zip(matched) {
        matched_row(&mut s, net, r, m);
    }
    s
}

pub use super::options::Method;

/// What happened to one track of a file.
#[derive(Debug, Clone)]
pub struct TrackOutcome {
    /// The track's identifier.
    pub track_id: String,
    /// Rows (indices into the file's rows), in order.
    pub rows: Vec<usize>,
    /// Points matched.
    pub matched: usize,
    /// Breaks, with indices counted within the track.
    pub breaks: Vec<super::Break>,
    /// Runs of unmatched points, indices counted within the track.
    pub unmatched: Vec<super::UnmatchedSpan>,
    /// The complete matched path, in driving order.
    pub path: Vec<super::cpath::PathStep>,
    /// The HMM's parameters used (search radius, σ, caps), with the
    /// defaults taken from this track.
    pub params: super::HmmParams,
}

impl TrackOutcome {
    /// An empty outcome (to be filled by [`FileMatcher::match_rows_into`]).
    fn empty() -> Self {
        TrackOutcome {
            track_id: String::new(),
            rows: Vec::new(),
            matched: 0,
            breaks: Vec::new(),
            unmatched: Vec::new(),
            path: Vec::new(),
            params: super::HmmParams::default(),
        }
    }
}

/// The match of a file's rows ([`FileMatcher::match_rows_into`]): one point
/// per row, in row order, and what happened to each track, in order of
/// first appearance. Kept between files, its memory is reused.
#[derive(Debug, Clone, Default)]
pub struct FileMatch {
    /// The match of each row.
    pub points: Vec<MatchedPoint>,
    /// Each track's outcome.
    pub tracks: Vec<TrackOutcome>,
}

/// Matches every track of a file; the result has one point per row, in row order.
pub fn match_rows(
    net: &Network,
    rows: &[TrackRow],
    opts: &super::options::MatchOptions,
) -> (Vec<MatchedPoint>, Vec<TrackOutcome>) {
    // One cache of network searches for the whole file: fleet files hold
    // many tracks on the same roads.
    FileMatcher::new(net).match_rows(rows, opts)
}

/// [`match_rows`] with a cache of network searches kept by the caller
/// (e.g. between files on one map, as a peer's precomputed table is);
/// `None` starts one. Results may differ from a cold cache's only where a
/// transition's route lies at its search bound.
pub fn match_rows_with<'a>(
    net: &'a Network,
    rows: &[TrackRow],
    opts: &super::options::MatchOptions,
    distances: &mut Option<super::NetworkDistances<'a>>,
) -> (Vec<MatchedPoint>, Vec<TrackOutcome>) {
    let mut m = FileMatcher::with_distances(
        net,
        distances
            .take()
            .unwrap_or_else(|| super::NetworkDistances::new(net)),
    );
    let r = m.match_rows(rows, opts);
    *distances = Some(m.into_distances());
    r
}

/// A matcher of track files kept across files and tracks: one HMM matcher
/// (its window, steps and buffers) restarted for each track, its cache of
/// network searches, and the per-track buffers, so that matching many
/// files on one map (a server, a benchmark's repeats) allocates none of
/// them again. [`Self::match_rows`] gives exactly what [`match_rows`] gives
/// with the same cache of searches; [`Self::forget_searches`] empties the
/// cache (a cold start, as a new matcher's) and keeps its memory.
#[derive(Debug)]
pub struct FileMatcher<'a> {
    net: &'a Network,
    hmm: Option<super::HmmMatcher<'a>>,
    /// The cache of searches while no HMM matcher holds it.
    distances: Option<super::NetworkDistances<'a>>,
    /// The streaming match's searches for its complete paths (its own:
    /// see [`super::stream`]).
    pub(super) path_distances: Option<super::NetworkDistances<'a>>,
    fixes: Vec<Fix>,
    points: Vec<MatchedPoint>,
    filled: Vec<bool>,
    /// σ̂'s scratch.
    sigma_buf: Vec<f64>,
    /// The complete paths' builder (its buffers kept across tracks).
    path_builder: super::cpath::PathBuilder,
}

impl<'a> FileMatcher<'a> {
    /// A matcher on `net` with an empty cache of network searches.
    pub fn new(net: &'a Network) -> Self {
        Self::with_distances(net, super::NetworkDistances::new(net))
    }

    /// A matcher on `net` starting from the searches of `distances`.
    pub fn with_distances(net: &'a Network, distances: super::NetworkDistances<'a>) -> Self {
        Self {
            net,
            hmm: None,
            distances: Some(distances),
            path_distances: None,
            fixes: Vec::new(),
            points: Vec::new(),
            filled: Vec::new(),
            sigma_buf: Vec::new(),
            path_builder: Default::default(),
        }
    }

    /// The cache of network searches.
    pub fn distances_mut(&mut self) -> &mut super::NetworkDistances<'a> {
        match self.hmm.as_mut() {
            Some(m) => m.distances_mut(),
            None => self.distances.as_mut().expect("a cache"),
        }
    }

    /// Empties the cache of network searches (the next file starts cold,
    /// with the same results as a new matcher's), keeping its memory.
    pub fn forget_searches(&mut self) {
        self.distances_mut().clear();
        if let Some(d) = self.path_distances.as_mut() {
            d.clear();
        }
    }

    /// The HMM's parameters for a track ([`MatchOptions::hmm_params`],
    /// σ̂ estimated in this matcher's scratch).
    ///
    /// [`MatchOptions::hmm_params`]: super::options::MatchOptions::hmm_params
    pub fn params(
        &mut self,
        opts: &super::options::MatchOptions,
        fixes: &[Fix],
    ) -> super::HmmParams {
        opts.hmm_params_with(self.net, fixes, &mut self.sigma_buf)
    }

    /// The network this matcher works on.
    pub fn network(&self) -> &'a Network {
        self.net
    }

    /// The HMM matcher for the next track, with `params`: the kept one
    /// restarted (its buffers and searches kept), else a new one on the
    /// cache. Give it back with [`Self::keep_hmm`].
    pub(super) fn hmm_for(&mut self, params: super::HmmParams) -> super::HmmMatcher<'a> {
        match self.hmm.take() {
            Some(mut m) => {
                m.restart(params);
                m
            }
            None => super::HmmMatcher::with_distances(
                self.net,
                params,
                self.distances.take().expect("the cache"),
            ),
        }
    }

    /// Keeps a track's HMM matcher (from [`Self::hmm_for`]) for the next.
    pub(super) fn keep_hmm(&mut self, m: super::HmmMatcher<'a>) {
        self.hmm = Some(m);
    }

    /// The cache of network searches, to keep elsewhere.
    pub fn into_distances(self) -> super::NetworkDistances<'a> {
        match self.hmm {
            Some(m) => m.into_distances(),
            None => self.distances.expect("a cache"),
        }
    }

    /// Matches every track of a file; one point per row, in row order.
    pub fn match_rows(
        &mut self,
        rows: &[TrackRow],
        opts: &super::options::MatchOptions,
    ) -> (Vec<MatchedPoint>, Vec<TrackOutcome>) {
        let mut out = FileMatch::default();
        self.match_rows_into(rows, opts, &mut out);
        (out.points, out.tracks)
    }

    /// [`Self::match_rows`] into `out` (its contents replaced), reusing its
    /// memory: matching file after file (a server, a benchmark's repeats)
    /// into one `FileMatch` allocates nothing once it has grown.
    pub fn match_rows_into(
        &mut self,
        rows: &[TrackRow],
        opts: &super::options::MatchOptions,
        out: &mut FileMatch,
    ) {
        use super::{IncrementalMatcher, IncrementalParams, Matcher};
        let net = self.net;
        let n = self.group_into(rows, &mut out.tracks);
        // Rows not in any track's output yet hold a placeholder.
        let placeholder = MatchedPoint::unmatched(
            0,
            &Fix {
                t_s: f64::NAN,
                enu: [f64::NAN; 2],
                heading_rad: None,
            },
        );
        out.points.clear();
        out.points.resize(rows.len(), placeholder);
        self.filled.clear();
        self.filled.resize(rows.len(), false);
        for outcome in &mut out.tracks[..n] {
            let idx = &outcome.rows;
            let mut fixes = std::mem::take(&mut self.fixes);
            fixes.clear();
            fixes.extend(idx.iter().map(|&i| to_fix(net, &rows[i])));
            let params = self.params(opts, &fixes);
            let mut points = std::mem::take(&mut self.points);
            points.clear();
            match opts.method {
                Method::Incremental => {
                    let mut m = IncrementalMatcher::new(
                        net,
                        IncrementalParams {
                            // Its own tuned radius unless one is given.
                            search_radius_m: opts
                                .radius_m
                                .unwrap_or(IncrementalParams::default().search_radius_m),
                            ..IncrementalParams::default()
                        },
                    );
                    for f in &fixes {
                        m.push(f, &mut points);
                    }
                    m.finish(&mut points);
                    outcome.breaks.clear();
                    outcome.breaks.extend_from_slice(m.breaks());
                    // What `cpath::complete_path` gives: its own searches.
                    let mut d = super::NetworkDistances::new(net);
                    d.uturn_penalty_m = params.uturn_penalty_m;
                    self.path_builder.complete_into(
                        &mut d,
                        net,
                        &points,
                        &outcome.breaks,
                        &params,
                        &mut outcome.path,
                    );
                }
                Method::Hmm => {
                    // The kept matcher restarted in place (its buffers and
                    // searches kept), else a new one on the cache.
                    match self.hmm.as_mut() {
                        Some(m) => m.restart(params),
                        None => {
                            self.hmm = Some(super::HmmMatcher::with_distances(
                                net,
                                params,
                                self.distances.take().expect("the cache"),
                            ))
                        }
                    }
                    let m = self.hmm.as_mut().expect("a matcher");
                    for f in &fixes {
                        m.push(f, &mut points);
                    }
                    m.finish(&mut points);
                    outcome.breaks.clear();
                    outcome.breaks.extend_from_slice(m.breaks());
                    self.path_builder.complete_into(
                        m.distances_mut(),
                        net,
                        &points,
                        &outcome.breaks,
                        &params,
                        &mut outcome.path,
                    );
                }
            }
            outcome.matched = points.iter().filter(|p| p.state.is_matched()).count();
            super::unmatched_spans_into(&points, &mut outcome.unmatched);
            for p in &points {
                let i = idx[p.index as usize];
                out.points[i] = *p;
                self.filled[i] = true;
            }
            outcome.params = params;
            self.points = points;
            self.fixes = fixes;
        }
        for (i, p) in out.points.iter_mut().enumerate() {
            if !self.filled[i] {
                *p = MatchedPoint::unmatched(i as u64, &to_fix(net, &rows[i]));
            }
        }
    }

    /// [`group_tracks`] into `tracks`' ids and rows (the outcomes there
    /// reused, extra ones dropped): the number of tracks.
    fn group_into(&mut self, rows: &[TrackRow], tracks: &mut Vec<TrackOutcome>) -> usize {
        // Tracks by id once there are more than a few (a linear scan
        // before: no hashing, no allocation).
        const SCAN: usize = 8;
        let mut at: FxHashMap<&str, usize> = FxHashMap::default();
        let mut n = 0;
        // The group of the previous row, whose id the next row most often
        // shares (tracks come in runs).
        let mut last: Option<(&str, usize)> = None;
        for (i, r) in rows.iter().enumerate() {
            let id = r.track_id.as_str();
            let k = match last {
                Some((l, k)) if l == id => k,
                _ => {
                    let found = if n <= SCAN {
                        tracks[..n].iter().position(|t| t.track_id == id)
                    } else {
                        if at.is_empty() {
                            for (k, t) in tracks[..n].iter().enumerate() {
                                at.insert(rows[t.rows[0]].track_id.as_str(), k);
                            }
                        }
                        at.get(id).copied()
                    };
                    match found {
                        Some(k) => k,
                        None => {
                            if n == tracks.len() {
                                tracks.push(TrackOutcome::empty());
                            }
                            let t = &mut tracks[n];
                            t.track_id.clear();
                            t.track_id.push_str(id);
                            t.rows.clear();
                            if !at.is_empty() {
                                at.insert(id, n);
                            }
                            n += 1;
                            n - 1
                        }
                    }
                }
            };
            if last.is_none_or(|(_, j)| j != k) {
                // Room for the whole run of rows of this track at once.
                let run = rows[i..].iter().take_while(|q| q.track_id == id).count();
                tracks[k].rows.reserve(run);
            }
            last = Some((id, k));
            tracks[k].rows.push(i);
        }
        // Extra outcomes of an earlier file: their paths' section lists kept.
        for t in tracks.drain(n..) {
            let mut path = t.path;
            self.path_builder.recycle(&mut path);
        }
        n
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn csv_fields() {
        let fields = |text: &str| -> Vec<String> {
            let mut t = CsvTable::open(Path::new("f.csv"), text).unwrap().unwrap();
            assert!(t.next_record(Path::new("f.csv")).unwrap().is_none());
            t.names
        };
        assert_eq!(fields("a, b ,c"), ["a", "b", "c"]);
        assert_eq!(
            fields("\"x,y\",\"say \"\"hi\"\"\","),
            ["x,y", "say \"hi\"", ""]
        );
        let field = |f: &str| {
            let mut s = String::new();
            push_csv_field(&mut s, f);
            s
        };
        assert_eq!(field("a,b"), "\"a,b\"");
        assert_eq!(field("say \"hi\""), "\"say \"\"hi\"\"\"");
        assert_eq!(field("plain"), "plain");
    }

    #[test]
    fn reads_optional_columns_in_any_order() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("t.csv");
        std::fs::write(
            &p,
            "\u{feff}lon,lat,t_s,speed_mps,heading_deg,track_id\r\n24.94,60.17,0,5,90,a\r\n\r\n24.95,60.17,1,,,b\r\n24.96,60.17,0.5,,,b\r\n",
        )
        .unwrap();
        let e = read_track(&p).unwrap_err().to_string();
        assert!(
            e.contains("t.csv:5") && e.contains("not in time order") && e.contains("track 'b'"),
            "{e}"
        );
        std::fs::write(&p, "lon,lat,t_s,speed_mps,heading_deg,track_id\n24.94,60.17,0,5,90,a\n24.95,60.17,1,,,b\n24.96,60.17,0.5,,,a\n").unwrap();
        let rows = read_track(&p).unwrap();
        assert_eq!(rows.len(), 3);
        assert_eq!(rows[0].heading_deg, Some(90.0));
        assert_eq!(rows[0].speed_mps, Some(5.0));
        assert_eq!(rows[1].heading_deg, None);
        assert_eq!(rows[2].line, 4);
        let groups = group_tracks(&rows);
        assert_eq!(
            groups,
            vec![("a".to_string(), vec![0, 2]), ("b".to_string(), vec![1])]
        );
    }

    #[test]
    fn errors_name_the_line_and_the_problem() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("t.csv");
        let err = |text: &str| {
            std::fs::write(&p, text).unwrap();
            read_track(&p).unwrap_err().to_string()
        };
        let e = err("t_s,lat,lon\n\n0,60.17\n");
        assert!(
            e.contains("t.csv:3") && e.contains("2 fields, the header has 3"),
            "{e}"
        );
        let e = err("\ntime, lat,lon\r\n0,1,2\n");
        assert!(
            e.contains("t.csv:2") && e.contains("missing column(s) t_s (header: 'time, lat,lon';"),
            "{e}"
        );
        let e = err("\n \nt_s,lat,lon\n\n");
        assert!(e.contains("t.csv:3") && e.contains("no data rows"), "{e}");
        let e = err("  \n\n");
        assert!(e.contains("empty file"), "{e}");
        let e = err("t_s,lat,lon\n \"\" \n");
        assert!(
            e.contains("t.csv:2") && e.contains("1 fields, the header has 3"),
            "{e}"
        );
        let e = err("t_s,lat,lon\n0,60.17,24.9\n1,60.17,abc\n");
        assert!(
            e.contains("t.csv:3") && e.contains("lon 'abc' is not a number"),
            "{e}"
        );
        std::fs::write(&p, b"t_s,lat,lon\n0,60.17,\xff\n").unwrap();
        let e = read_track(&p).unwrap_err().to_string();
        assert!(e.contains("not UTF-8"), "{e}");
        std::fs::write(&p, "t_s,lat,lon,track_id\n0,60.17,24.9,\"a,\"\"b\"\"\"\n").unwrap();
        assert_eq!(read_track(&p).unwrap()[0].track_id, "a,\"b\"");
    }
}
