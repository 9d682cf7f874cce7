//! A CSV track matched as it is read (issue 17 point 6): memory of the
//! order of the matcher's lag window, not of the file.
//!
//! - The file is read in chunks of whole records ([`CHUNK_BYTES`]), each
//!   checked as TRACK.csv's rows are (same messages, same line numbers).
//! - Each track is matched by its own matcher as its rows arrive; a track's
//!   matched points are written as the matcher decides them (the HMM: at
//!   most `lag` steps late; the incremental matcher: at once), so the output
//!   is written in input order without holding it.
//! - The matcher's defaults taken from the track (search radius, σ̂) are
//!   estimated from its first [`PREFIX_FIXES`] fixes, held before matching
//!   starts: identical to the whole-file estimate for tracks up to that
//!   length (a sample of 2,000 spread over the whole track beyond it).
//! - The complete path is built point by point ([`PathBuilder`]); its steps
//!   are kept only when asked for (the path files), else folded into the
//!   length driven per road.
//!
//! Tracks must be contiguous in the file to stream (a fleet file that
//! interleaves them is matched whole: [`match_csv_stream`] returns `None`
//! as soon as a finished track reappears).

use super::cpath::{PathBuilder, PathStep};
use super::evaluate::RoadLengths;
use super::options::{MatchOptions, Method};
use super::track::{
    columns, matched_row, parse_row, to_fix, Columns, CsvTable, FileMatcher, TrackRow,
};
use super::{
    Break, Fix, HmmMatcher, HmmParams, IncrementalMatcher, IncrementalParams, MatchedPoint,
    Matcher, NetworkDistances,
};
use crate::error::{Error, Result};
use crate::network::Network;
use rustc_hash::{FxHashMap, FxHashSet};
use std::collections::VecDeque;
use std::io::{BufRead, Read, Write};
use std::path::{Path, PathBuf};

/// Bytes read at a time (whole records).
pub const CHUNK_BYTES: usize = 1 << 20;
/// The longest line read (bytes): a track row is some 30-100 bytes.
pub const MAX_LINE_BYTES: usize = 1 << 16;
/// Fixes of a track held to estimate its defaults before matching starts.
pub const PREFIX_FIXES: usize = 4000;

/// TRACK.csv read chunk by chunk.
pub struct TrackCsvStream {
    path: PathBuf,
    reader: std::io::BufReader<std::fs::File>,
    names: Vec<String>,
    cols: Option<Columns>,
    header_line: usize,
    /// Lines before the next chunk.
    lines: usize,
    last_t: FxHashMap<String, (f64, usize)>,
    rows: usize,
    buf: Vec<u8>,
    eof: bool,
}

impl TrackCsvStream {
    /// Opens `path`.
    pub fn open(path: &Path) -> Result<Self> {
        let f = std::fs::File::open(path).map_err(|e| Error::io(path, e))?;
        Ok(TrackCsvStream {
            path: path.to_path_buf(),
            reader: std::io::BufReader::with_capacity(1 << 16, f),
            names: Vec::new(),
            cols: None,
            header_line: 0,
            lines: 0,
            last_t: FxHashMap::default(),
            rows: 0,
            buf: Vec::with_capacity(CHUNK_BYTES + 4096),
            eof: false,
        })
    }

    /// Reads whole lines until the chunk is full and no quoted field is
    /// open (a quoted field may hold line ends), or the file ends.
    fn fill(&mut self) -> Result<()> {
        self.buf.clear();
        let mut quotes = 0usize;
        loop {
            let before = self.buf.len();
            let n = (&mut self.reader)
                .take(MAX_LINE_BYTES as u64 + 1)
                .read_until(b'\n', &mut self.buf)
                .map_err(|e| Error::io(&self.path, e))?;
            if n == 0 {
                self.eof = true;
                return Ok(());
            }
            if n > MAX_LINE_BYTES {
                // Endless input (/dev/zero) or not a track CSV: stop before
                // holding it.
                let line =
                    self.lines + 1 + self.buf[..before].iter().filter(|&&b| b == b'\n').count();
                return Err(Error::table(
                    &self.path,
                    line,
                    format!("a line longer than {MAX_LINE_BYTES} bytes: not a track CSV"),
                ));
            }
            quotes += self.buf[before..].iter().filter(|&&b| b == b'"').count();
            let blank = self.cols.is_none() && self.buf.iter().all(u8::is_ascii_whitespace);
            if self.buf.len() >= CHUNK_BYTES && quotes % 2 == 0 && !blank {
                return Ok(());
            }
        }
    }

    /// The next rows into `out` (cleared); `false` when the file has ended.
    pub fn next_rows(&mut self, out: &mut Vec<TrackRow>) -> Result<bool> {
        out.clear();
        if self.eof {
            return self.end();
        }
        self.fill()?;
        let buf = std::mem::take(&mut self.buf);
        let result = self.parse(&buf, out);
        let newlines = buf.iter().filter(|&&b| b == b'\n').count();
        self.buf = buf;
        result?;
        self.lines += newlines;
        if self.eof && out.is_empty() {
            return self.end();
        }
        Ok(true)
    }

    fn parse(&mut self, bytes: &[u8], out: &mut Vec<TrackRow>) -> Result<()> {
        let path = self.path.clone();
        let mut text = std::str::from_utf8(bytes).map_err(|e| {
            let at = e.valid_up_to();
            let line = self.lines + 1 + bytes[..at].iter().filter(|&&b| b == b'\n').count();
            Error::table(&path, line, format!("not UTF-8 text ({e})"))
        })?;
        let mut table = match &self.cols {
            Some(_) => CsvTable::continued(text, self.names.clone(), self.lines),
            None => {
                if let Some(t) = text.strip_prefix('\u{feff}') {
                    text = t;
                }
                let Some(table) = CsvTable::open(&path, text)? else {
                    // Only blank lines so far (the chunk reached the end).
                    return Ok(());
                };
                self.cols = Some(columns(&path, &table)?);
                self.names = table.names.clone();
                self.header_line = table.header_line;
                table
            }
        };
        let cols = self.cols.as_ref().expect("columns read");
        while let Some((line, f)) = table.next_record(&path)? {
            out.push(parse_row(&path, line, f, cols, &mut self.last_t)?);
        }
        self.rows += out.len();
        Ok(())
    }

    /// The end of the file: the checks of a whole file's end.
    fn end(&self) -> Result<bool> {
        if self.cols.is_none() {
            return Err(Error::table(
                &self.path,
                1,
                "empty file: expected a header row t_s,lat,lon",
            ));
        }
        if self.rows == 0 {
            return Err(Error::table(
                &self.path,
                self.header_line,
                "no data rows after the header",
            ));
        }
        Ok(false)
    }
}

/// What one streamed track gave.
#[derive(Debug, Clone)]
pub struct StreamedTrack {
    /// The track's identifier.
    pub track_id: String,
    /// Points.
    pub points: usize,
    /// Points matched.
    pub matched: usize,
    /// Breaks, each with the line of the first fix after it.
    pub breaks: Vec<(Break, usize)>,
    /// Unmatched runs: first and last line, first and last time, points.
    pub unmatched: Vec<([usize; 2], [f64; 2], u64)>,
    /// The complete path's steps (when kept).
    pub path: Vec<PathStep>,
    /// Continuous pieces of the complete path.
    pub pieces: usize,
    /// The parameters used.
    pub params: HmmParams,
}

/// What a streamed match gave: per track, and the length driven per road.
#[derive(Debug, Clone, Default)]
pub struct StreamedMatch {
    /// Tracks, in file order.
    pub tracks: Vec<StreamedTrack>,
    /// Length of the complete path per road (all tracks).
    pub lengths: RoadLengths,
}

/// The track's matcher, and the network searches of its complete path
/// (its own: the path's searches, made while the matcher runs, must not
/// change the matcher's cache, whose contents can decide a transition at
/// its bound).
#[allow(clippy::large_enum_variant)] // one per track being matched
enum Which<'a> {
    Hmm(HmmMatcher<'a>, NetworkDistances<'a>),
    Incremental(IncrementalMatcher<'a>, NetworkDistances<'a>),
}

/// One track being matched.
struct Active<'a> {
    out: StreamedTrack,
    /// Rows pushed (or held) whose points are not yet written.
    rows: VecDeque<TrackRow>,
    /// Fixes held before matching starts.
    prefix: Vec<Fix>,
    matcher: Option<Which<'a>>,
    builder: PathBuilder,
    breaks_seen: usize,
    open_span: bool,
}

/// The streaming match's state.
struct Streamer<'a, 'w, W: Write> {
    net: &'a Network,
    opts: &'w MatchOptions,
    keep_path: bool,
    out: &'w mut W,
    out_path: &'w Path,
    text: String,
    points: Vec<MatchedPoint>,
    /// The HMM matcher (restarted for each track), its cache of searches
    /// and the complete paths' searches, kept across tracks and files.
    files: &'w mut FileMatcher<'a>,
    result: StreamedMatch,
}

impl<'a, W: Write> Streamer<'a, '_, W> {
    fn start(&mut self, a: &mut Active<'a>) -> Result<()> {
        let params = self.files.params(self.opts, &a.prefix);
        a.out.params = params;
        let m = match self.opts.method {
            Method::Hmm => {
                // The previous track's matcher restarted (its buffers and
                // network searches kept), else a new one.
                let m = self.files.hmm_for(params);
                let mut d = self
                    .files
                    .path_distances
                    .take()
                    .unwrap_or_else(|| NetworkDistances::new(self.net));
                d.uturn_penalty_m = params.uturn_penalty_m;
                Which::Hmm(m, d)
            }
            Method::Incremental => {
                let inc = IncrementalParams {
                    search_radius_m: self
                        .opts
                        .radius_m
                        .unwrap_or(IncrementalParams::default().search_radius_m),
                    ..IncrementalParams::default()
                };
                let mut d = NetworkDistances::new(self.net);
                d.uturn_penalty_m = params.uturn_penalty_m;
                Which::Incremental(IncrementalMatcher::new(self.net, inc), d)
            }
        };
        a.matcher = Some(m);
        // The rows held are the prefix's (none written yet).
        let prefix = std::mem::take(&mut a.prefix);
        let lines: Vec<usize> = a.rows.iter().map(|r| r.line).collect();
        for (f, line) in prefix.iter().zip(lines) {
            self.push(a, f, line)?;
        }
        Ok(())
    }

    /// Pushes a fix (its row already in `a.rows`) and writes what comes out.
    fn push(&mut self, a: &mut Active<'a>, fix: &Fix, line: usize) -> Result<()> {
        let mut pts = std::mem::take(&mut self.points);
        pts.clear();
        let breaks = match a.matcher.as_mut().expect("started") {
            Which::Hmm(m, _) => {
                m.push(fix, &mut pts);
                m.breaks().len()
            }
            Which::Incremental(m, _) => {
                m.push(fix, &mut pts);
                m.breaks().len()
            }
        };
        if breaks > a.breaks_seen {
            let bs = match a.matcher.as_ref().expect("started") {
                Which::Hmm(m, _) => m.breaks(),
                Which::Incremental(m, _) => m.breaks(),
            };
            // A break is recorded at the fix being pushed.
            for b in &bs[a.breaks_seen..] {
                a.out.breaks.push((*b, line));
            }
            a.breaks_seen = breaks;
        }
        let r = self.emit(a, &pts);
        self.points = pts;
        r
    }

    /// Writes matched points (in track order) and builds the path.
    fn emit(&mut self, a: &mut Active<'a>, pts: &[MatchedPoint]) -> Result<()> {
        self.text.clear();
        for p in pts {
            let row = a.rows.pop_front().expect("a row per point");
            matched_row(&mut self.text, self.net, &row, p);
            if p.state.is_matched() {
                a.out.matched += 1;
                a.open_span = false;
            } else {
                match a.out.unmatched.last_mut() {
                    Some(s) if a.open_span => {
                        s.0[1] = row.line;
                        s.1[1] = p.t_s;
                        s.2 += 1;
                    }
                    _ => a.out.unmatched.push(([row.line; 2], [p.t_s; 2], 1)),
                }
                a.open_span = true;
            }
            let params = a.out.params;
            match a.matcher.as_mut().expect("started") {
                Which::Hmm(m, d) => a.builder.push(d, self.net, p, m.breaks(), &params),
                Which::Incremental(m, d) => a.builder.push(d, self.net, p, m.breaks(), &params),
            }
            self.drain_path(a);
        }
        self.out
            .write_all(self.text.as_bytes())
            .map_err(|e| Error::io(self.out_path, e))
    }

    fn drain_path(&mut self, a: &mut Active<'a>) {
        if self.keep_path {
            return;
        }
        for s in a.builder.steps.drain(..) {
            *self
                .result
                .lengths
                .entry(self.net.roads[s.road as usize].attributes.id.clone())
                .or_default() += s.length_m();
            a.out.pieces = a.out.pieces.max(s.piece as usize + 1);
        }
    }

    fn finish(&mut self, mut a: Active<'a>) -> Result<()> {
        if a.matcher.is_none() {
            self.start(&mut a)?;
        }
        let mut pts = std::mem::take(&mut self.points);
        pts.clear();
        match a.matcher.as_mut().expect("started") {
            Which::Hmm(m, _) => m.finish(&mut pts),
            Which::Incremental(m, _) => m.finish(&mut pts),
        }
        self.emit(&mut a, &pts)?;
        self.points = pts;
        let params = a.out.params;
        match a.matcher.take().expect("started") {
            Which::Hmm(m, mut d) => {
                a.builder.finish(&mut d, self.net, m.breaks(), &params);
                self.files.keep_hmm(m);
                self.files.path_distances = Some(d);
            }
            Which::Incremental(m, mut d) => a.builder.finish(&mut d, self.net, m.breaks(), &params),
        }
        self.drain_path(&mut a);
        if self.keep_path {
            for s in &a.builder.steps {
                *self
                    .result
                    .lengths
                    .entry(self.net.roads[s.road as usize].attributes.id.clone())
                    .or_default() += s.length_m();
            }
            a.out.pieces = a.builder.steps.last().map_or(0, |s| s.piece as usize + 1);
            a.out.path = std::mem::take(&mut a.builder.steps);
        }
        self.result.tracks.push(a.out);
        Ok(())
    }
}

/// Matches the CSV track `path` as it is read, writing MATCHED.csv's rows
/// (header included) to `out` (the file `out_path`) as they are decided. `keep_path`: keep the
/// complete path's steps (for the path files). `None` when the file
/// interleaves its tracks (match it whole instead).
pub fn match_csv_stream<W: Write>(
    net: &Network,
    path: &Path,
    opts: &MatchOptions,
    keep_path: bool,
    out: &mut W,
    out_path: &Path,
) -> Result<Option<StreamedMatch>> {
    FileMatcher::new(net).match_csv_stream(path, opts, keep_path, out, out_path)
}

impl FileMatcher<'_> {
    /// [`match_csv_stream`] by this matcher (its HMM matcher, buffers and
    /// network searches kept from the files before, and for the next).
    pub fn match_csv_stream<W: Write>(
        &mut self,
        path: &Path,
        opts: &MatchOptions,
        keep_path: bool,
        out: &mut W,
        out_path: &Path,
    ) -> Result<Option<StreamedMatch>> {
        stream_with(self, path, opts, keep_path, out, out_path)
    }
}

fn stream_with<W: Write>(
    files: &mut FileMatcher<'_>,
    path: &Path,
    opts: &MatchOptions,
    keep_path: bool,
    out: &mut W,
    out_path: &Path,
) -> Result<Option<StreamedMatch>> {
    let net = files.network();
    let mut reader = TrackCsvStream::open(path)?;
    out.write_all(super::track::MATCHED_HEADER.as_bytes())
        .map_err(|e| Error::io(out_path, e))?;
    let mut s = Streamer {
        net,
        opts,
        keep_path,
        out,
        out_path,
        text: String::new(),
        points: Vec::new(),
        files,
        result: StreamedMatch::default(),
    };
    let mut done: FxHashSet<String> = FxHashSet::default();
    let mut active: Option<Active> = None;
    let mut rows = Vec::new();
    while reader.next_rows(&mut rows)? {
        for row in rows.drain(..) {
            if active
                .as_ref()
                .is_some_and(|a| a.out.track_id != row.track_id)
            {
                let a = active.take().expect("active");
                done.insert(a.out.track_id.clone());
                s.finish(a)?;
            }
            if done.contains(&row.track_id) {
                return Ok(None);
            }
            let a = active.get_or_insert_with(|| Active {
                out: StreamedTrack {
                    track_id: row.track_id.clone(),
                    points: 0,
                    matched: 0,
                    breaks: Vec::new(),
                    unmatched: Vec::new(),
                    path: Vec::new(),
                    pieces: 0,
                    params: HmmParams::default(),
                },
                rows: VecDeque::new(),
                prefix: Vec::new(),
                matcher: None,
                builder: PathBuilder::default(),
                breaks_seen: 0,
                open_span: false,
            });
            a.out.points += 1;
            let fix = to_fix(net, &row);
            let line = row.line;
            a.rows.push_back(row);
            if a.matcher.is_some() {
                s.push(a, &fix, line)?;
            } else {
                a.prefix.push(fix);
                if a.prefix.len() >= PREFIX_FIXES {
                    s.start(a)?;
                }
            }
        }
    }
    if let Some(a) = active.take() {
        s.finish(a)?;
    }
    Ok(Some(s.result))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every record of a table (the header first) with its line number.
    fn table_records(text: &str) -> Vec<(usize, Vec<String>)> {
        let path = Path::new("t.csv");
        let Some(mut t) = CsvTable::open(path, text).unwrap() else {
            return Vec::new();
        };
        let mut out = vec![(t.header_line, t.names.clone())];
        while let Some((line, r)) = t.next_record(path).unwrap() {
            out.push((line, r.iter().map(str::to_owned).collect()));
        }
        out
    }

    /// The table's fields, trimmed by `str::trim` into a record kept across
    /// reads, are the csv crate's own `Trim::All` fields (the former
    /// reader's): spaces, tabs, vertical tabs, form feeds, carriage
    /// returns, Unicode spaces (no-break, ideographic), quoted fields with
    /// blanks inside and around the quotes, empty and quoted empty fields,
    /// CRLF line ends, non-ASCII text; blank lines and lines of blanks are
    /// skipped with the line numbers counted as before.
    #[test]
    fn trimmed_fields_are_the_csv_crates_trim_all() {
        let texts = [
            "t_s,lat,lon\n0,60.1,24.9\n1, 60.2 ,\t24.8\t\n",
            " t_s , lat,lon \r\n\x0b2\x0c,\u{a0}60.3\u{3000},24.7\r\n",
            "a,b,c\n\" x \",\"\",\"  \"\n\"q,r\", s\u{2003} ,\u{e9}t\u{e9}\n",
            "a,b\n, \n\t,\u{85}x\u{85}\n",
        ];
        for text in texts {
            let mut want = Vec::new();
            let mut rdr = csv::ReaderBuilder::new()
                .has_headers(false)
                .flexible(true)
                .trim(csv::Trim::All)
                .from_reader(text.as_bytes());
            for r in rdr.records() {
                want.push(r.unwrap().iter().map(str::to_owned).collect::<Vec<_>>());
            }
            let got: Vec<_> = table_records(text).into_iter().map(|(_, f)| f).collect();
            assert_eq!(got, want, "{text:?}");
        }
        // Blank lines and lines of blanks skipped, `""` kept, lines counted.
        let got = table_records("\n  \nt_s\n\n0\n \t \n1\n\"\"\n");
        let f = |v: &str| vec![v.to_string()];
        assert_eq!(
            got,
            vec![(3, f("t_s")), (5, f("0")), (7, f("1")), (8, f(""))]
        );
    }

    #[test]
    fn an_endless_line_is_an_error_not_a_memory_sink() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("t.csv");
        let mut text = String::from("t_s,lat,lon\n0,60.1,24.9\n");
        text.push_str(&"0".repeat(MAX_LINE_BYTES + 10));
        std::fs::write(&p, text).unwrap();
        let mut r = TrackCsvStream::open(&p).unwrap();
        let mut rows = Vec::new();
        let e = r.next_rows(&mut rows).unwrap_err().to_string();
        assert!(
            e.contains("t.csv:3") && e.contains("not a track CSV"),
            "{e}"
        );
    }

    #[test]
    fn chunks_keep_line_numbers_and_checks() {
        // Rows across several chunks: the time-order check and the line
        // numbers carry over.
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("t.csv");
        let mut text = String::from("\nt_s,lat,lon\n");
        let n = 2 * CHUNK_BYTES / 20;
        for i in 0..n {
            text.push_str(&format!("{i},60.1000000,24.9\n"));
        }
        text.push_str("1,60.1,24.9\n");
        std::fs::write(&p, text).unwrap();
        let mut r = TrackCsvStream::open(&p).unwrap();
        let mut rows = Vec::new();
        let mut seen = 0;
        let e = loop {
            match r.next_rows(&mut rows) {
                Ok(true) => {
                    for row in &rows {
                        assert_eq!(row.line, seen + 3);
                        seen += 1;
                    }
                }
                Ok(false) => panic!("no error"),
                Err(e) => break e.to_string(),
            }
        };
        assert!(seen > CHUNK_BYTES / 20, "{seen}");
        let line = n + 3;
        assert!(
            e.contains(&format!("t.csv:{line}")) && e.contains("not in time order"),
            "{e}"
        );
    }
}
