//! Reading an output folder for the report: the required files strictly
//! (a clear error naming the file and the field), the optional ones
//! leniently, each missing or unusable one recorded as a note the page
//! shows ("what is missing") and `waymark report` prints.

use super::map::{CoveragePiece, MapOverlay, MapTag};
use super::{read_errors_csv, read_plan_profile_csv, read_tag_passes_csv, ErrorRow, PassRow};
use crate::error::{Error, Result};
use std::path::{Path, PathBuf};

/// Largest file of an output folder the report reads (bytes): errors.csv of
/// a 30-day drive at a 1 s output interval is about 250 MB.
pub const MAX_REPORT_FILE_BYTES: u64 = 1 << 30;

/// Opens `path` for reading at most [`MAX_REPORT_FILE_BYTES`]: a regular
/// file over the limit is an error naming it; anything else (an endless
/// `/dev/zero`) is cut at the limit, so no reader holds more.
pub(super) fn open_limited(path: &Path) -> std::io::Result<std::io::Take<std::fs::File>> {
    use std::io::Read as _;
    let f = std::fs::File::open(path)?;
    if f.metadata()
        .is_ok_and(|m| m.is_file() && m.len() > MAX_REPORT_FILE_BYTES)
    {
        return Err(std::io::Error::other(format!(
            "larger than the limit of {} for a file the report reads",
            crate::fsio::human_bytes(MAX_REPORT_FILE_BYTES)
        )));
    }
    Ok(f.take(MAX_REPORT_FILE_BYTES))
}

/// A folder file's text, read within [`MAX_REPORT_FILE_BYTES`] (an endless
/// input is refused at the limit) as [`crate::fsio::read_text_limited`]
/// reads every input; `what` names it in the error ("plan", "coverage").
pub(super) fn read_text(path: &Path, what: &str) -> Result<String> {
    crate::fsio::read_text_limited(path, MAX_REPORT_FILE_BYTES, what)
}

/// An optional file of the folder: absent, present but unusable (the
/// error, for a note), or its text.
pub(super) enum Optional {
    /// No file of that name.
    Absent,
    /// There, but it cannot be read (too large, not UTF-8, not a file).
    Unreadable(Error),
    /// Its text.
    Text(String),
}

/// Reads an optional file of the folder within `limit` bytes, telling an
/// absent file from one that cannot be read: a note saying "missing" for a
/// file that is there but damaged sends the user looking in the wrong place.
pub(super) fn read_optional(path: &Path, limit: u64, what: &str) -> Optional {
    match std::fs::symlink_metadata(path) {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Optional::Absent,
        _ => match crate::fsio::read_text_limited(path, limit, what) {
            Ok(t) => Optional::Text(t),
            Err(e) => Optional::Unreadable(e),
        },
    }
}

/// Whether a file's last byte is not a line end: a file cut short while
/// written or copied (every CSV Waymark writes ends with one). `false` for
/// an empty or unreadable file.
pub(super) fn ends_mid_line(path: &Path) -> bool {
    use std::io::{Read as _, Seek as _, SeekFrom};
    let Ok(mut f) = std::fs::File::open(path) else {
        return false;
    };
    if f.seek(SeekFrom::End(-1)).is_err() {
        return false;
    }
    let mut last = [0u8; 1];
    f.read_exact(&mut last).is_ok() && last[0] != b'\n'
}

/// One row of the tag table: the installer file's columns and, where the
/// plan gives it, why the tag is there.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct TagRow {
    /// `tag_id`.
    pub tag_id: String,
    /// Latitude, longitude (degrees).
    pub lat_lon: [f64; 2],
    /// Height (m), when the file gives one.
    pub height_m: Option<f64>,
    /// Mounting as written (`road_surface`, `roadside`, `ceiling`).
    pub mounting: String,
    /// Road id (and name, when the plan gives one).
    pub road: String,
    /// Chainage along the road (m).
    pub chainage_m: Option<f64>,
    /// Side of the road.
    pub side: String,
    /// Why the tag is needed (the plan's `reason`), when given.
    pub reason: String,
    /// The 96-bit payload in hexadecimal.
    pub payload_hex: String,
    /// Installed already (kept from `existing_tags`).
    pub existing: bool,
}

impl TagRow {
    /// A row from one of `plan.json`'s tags: id, position, height, mounting,
    /// road, chainage (`road_chainage_m` where `chainage_m` is absent),
    /// reason and whether it is installed already; `None` without an id or
    /// a position. The plan has no side or payload (those are `tags.csv`'s).
    pub fn from_plan_tag(t: &serde_json::Value) -> Option<TagRow> {
        let (id, lat, lon) = (
            t["tag_id"].as_str()?,
            t["lat"].as_f64()?,
            t["lon"].as_f64()?,
        );
        Some(TagRow {
            tag_id: id.into(),
            lat_lon: [lat, lon],
            height_m: t["height_m"].as_f64(),
            mounting: t["mounting"].as_str().unwrap_or("").into(),
            road: t["road_id"].as_str().unwrap_or("").into(),
            chainage_m: t["chainage_m"]
                .as_f64()
                .or_else(|| t["road_chainage_m"].as_f64()),
            reason: t["reason"].as_str().unwrap_or("").into(),
            existing: t["existing"].as_bool().unwrap_or(false),
            ..Default::default()
        })
    }
}

/// A CSV reader's error on the `i`-th record (from 0) as one short phrase
/// starting with its line: "line 4: 7 fields, the header has 13" rather
/// than csv's "CSV error: record 3 (line: 4, byte: 131): found record with
/// 7 fields, but the previous record has 13 fields".
pub(super) fn record_error(e: &csv::Error, i: usize) -> String {
    let line = |pos: Option<&csv::Position>| pos.map_or(i as u64 + 2, |p| p.line());
    match e.kind() {
        csv::ErrorKind::UnequalLengths {
            pos,
            expected_len,
            len,
        } => format!(
            "line {}: {len} fields, the header has {expected_len}",
            line(pos.as_ref())
        ),
        csv::ErrorKind::Utf8 { pos, err } => format!(
            "line {}: field {} is not UTF-8 text",
            line(pos.as_ref()),
            err.field() + 1
        ),
        _ => format!("line {}: {e}", line(e.position())),
    }
}

/// Where the tag table's rows come from, as the page says.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum TagSource {
    /// The lines of a tags CSV (its file name): the folder's `tags.csv` or
    /// the tag file simulated with.
    File(String),
    /// `plan.json`'s own list (no tags CSV, or one without tags).
    Plan,
}

impl Default for TagSource {
    fn default() -> Self {
        TagSource::File("tags.csv".into())
    }
}

/// Reads a tags CSV with a strict header: its first line (after
/// legacy `#` lines) must name `tag_id`, `lat`, `lon` and `mounting`;
/// other known columns are taken when present.
pub fn read_tag_table(path: &Path) -> Result<Vec<TagRow>> {
    let fail = |m: String| Error::format(path, m);
    let mut r = csv::ReaderBuilder::new()
        .comment(Some(b'#'))
        .trim(csv::Trim::All)
        .from_reader(open_limited(path).map_err(|e| fail(format!("cannot read: {e}")))?);
    let headers = r
        .headers()
        .map_err(|e| fail(format!("bad header: {e}")))?
        .clone();
    let col = |name: &str| headers.iter().position(|h| h == name);
    let need = |name: &str| col(name).ok_or_else(|| fail(format!("missing column '{name}'")));
    let (ci, cla, clo, cm) = (
        need("tag_id")?,
        need("lat")?,
        need("lon")?,
        need("mounting")?,
    );
    let (ch, cr, cc, cs, cp, creason) = (
        col("height_m"),
        col("road_id"),
        col("chainage_m"),
        col("side"),
        col("payload_hex"),
        col("reason"),
    );
    let mut rows = Vec::new();
    for (i, rec) in r.records().enumerate() {
        let rec = rec.map_err(|e| fail(record_error(&e, i)))?;
        let line = rec.position().map_or(i as u64 + 2, |p| p.line());
        let text = |k: Option<usize>| k.and_then(|k| rec.get(k)).unwrap_or("").to_string();
        let number = |k: Option<usize>, name: &str| -> Result<Option<f64>> {
            match k.and_then(|k| rec.get(k)).filter(|v| !v.is_empty()) {
                None => Ok(None),
                Some(v) => v
                    .parse::<f64>()
                    .ok()
                    .filter(|x| x.is_finite())
                    .map(Some)
                    .ok_or_else(|| fail(format!("line {line}: '{name}' is not a number: {v:?}"))),
            }
        };
        let lat =
            number(Some(cla), "lat")?.ok_or_else(|| fail(format!("line {line}: no 'lat'")))?;
        let lon =
            number(Some(clo), "lon")?.ok_or_else(|| fail(format!("line {line}: no 'lon'")))?;
        rows.push(TagRow {
            tag_id: text(Some(ci)),
            lat_lon: [lat, lon],
            height_m: number(ch, "height_m")?,
            mounting: text(Some(cm)),
            road: text(cr),
            chainage_m: number(cc, "chainage_m")?,
            side: text(cs),
            reason: text(creason),
            payload_hex: text(cp),
            existing: false,
        });
    }
    Ok(rows)
}

/// Adds what `plan.json`'s tags say (road name, reason) to the table's
/// rows, and appends the plan's installed tags kept (which the installer
/// file leaves out).
pub fn merge_plan_tags(rows: &mut Vec<TagRow>, plan: &serde_json::Value) {
    let Some(tags) = plan["tags"].as_array() else {
        return;
    };
    let index: std::collections::HashMap<String, usize> = rows
        .iter()
        .enumerate()
        .map(|(i, r)| (r.tag_id.clone(), i))
        .collect();
    for t in tags {
        let Some(id) = t["tag_id"].as_str() else {
            continue;
        };
        let reason = t["reason"].as_str().unwrap_or("");
        let name = t["road_name"].as_str().unwrap_or("");
        if let Some(&i) = index.get(id) {
            let r = &mut rows[i];
            if r.reason.is_empty() {
                r.reason = reason.to_string();
            }
            if !name.is_empty() && !r.road.contains(name) {
                r.road = format!("{} ({name})", r.road);
            }
        } else if t["existing"].as_bool() == Some(true) {
            let Some(mut row) = TagRow::from_plan_tag(t) else {
                continue;
            };
            if row.reason.is_empty() {
                row.reason = "installed already".into();
            }
            rows.push(row);
        }
    }
}

/// Reads an area plan's `coverage.geojson`: directed road pieces
/// (LineStrings) with `bound_m` (`null` where neither a sampled chain nor
/// a straight walk drives: skipped), and `bound_without_tags_m` and `reason` when given.
pub fn read_coverage(path: &Path) -> Result<Vec<(CoveragePiece, Option<f64>, String)>> {
    let text = read_text(path, "coverage file")?;
    let gj: geojson::GeoJson = text
        .parse()
        .map_err(|e| Error::format(path, format!("invalid GeoJSON: {e}")))?;
    let geojson::GeoJson::FeatureCollection(fc) = gj else {
        return Err(Error::format(path, "not a FeatureCollection"));
    };
    let mut out = Vec::with_capacity(fc.features.len());
    for (i, f) in fc.features.iter().enumerate() {
        let props = f.properties.as_ref();
        let get = |k: &str| props.and_then(|p| p.get(k));
        // `null`: no sampled chain, chain beginning or straight walk drives this road piece,
        // so the plan predicts nothing there; it stays grey like the rest of the map.
        if get("bound_m").is_some_and(|v| v.is_null()) {
            continue;
        }
        let bound = get("bound_m").and_then(|v| v.as_f64()).ok_or_else(|| {
            Error::format(
                path,
                format!("feature {i}: 'bound_m' is missing or not a number"),
            )
        })?;
        let without = get("bound_without_tags_m").and_then(|v| v.as_f64());
        let reason = get("reason")
            .and_then(|v| v.as_str())
            .unwrap_or("")
            .to_string();
        let lines: Vec<Vec<Vec<f64>>> = match f.geometry.as_ref().map(|g| &g.value) {
            Some(geojson::Value::LineString(l)) => vec![l.clone()],
            Some(geojson::Value::MultiLineString(m)) => m.clone(),
            _ => {
                return Err(Error::format(
                    path,
                    format!("feature {i}: geometry is not a LineString"),
                ))
            }
        };
        let road = get("road_id")
            .and_then(|v| v.as_str())
            .map(|r| format!("road {r}: "))
            .unwrap_or_default();
        let mut info = format!("{road}predicted 95 % bound {bound:.1} m");
        if let Some(w) = without {
            info.push_str(&format!(" ({w:.0} m without tags)"));
        }
        if !reason.is_empty() {
            info.push_str(&format!("; {reason}"));
        }
        for l in lines {
            out.push((
                CoveragePiece {
                    line: l
                        .iter()
                        .filter(|p| p.len() >= 2)
                        .map(|p| [p[1], p[0]])
                        .collect(),
                    value_m: bound,
                    info: info.clone(),
                },
                without,
                reason.clone(),
            ));
        }
    }
    Ok(out)
}

/// Reads `inputs.json`: the scenario's and the tag file's paths when
/// simulated or planned. Every problem is a note.
pub(super) fn read_inputs(
    dir: &Path,
    notes: &mut Vec<String>,
) -> Option<(PathBuf, Option<PathBuf>)> {
    let path = dir.join("inputs.json");
    // inputs.json is a few hundred bytes; a scenario's limit is ample.
    let text = match read_optional(&path, crate::scenario::MAX_SCENARIO_BYTES, "inputs file") {
        Optional::Text(t) => t,
        Optional::Absent => {
            notes.push(
                "inputs.json is missing: where the scenario was is unknown, so the map is not drawn"
                    .into(),
            );
            return None;
        }
        Optional::Unreadable(e) => {
            notes.push(format!(
                "inputs.json cannot be read ({}): the map is not drawn",
                without_path(&e, &path)
            ));
            return None;
        }
    };
    let v: serde_json::Value = match serde_json::from_str(&text) {
        Ok(v) => v,
        Err(e) => {
            notes.push(format!(
                "inputs.json is not valid JSON ({e}): the map is not drawn"
            ));
            return None;
        }
    };
    let Some(scenario) = v["scenario_path"].as_str() else {
        notes.push(
            "inputs.json: 'scenario_path' is missing or not a string: the map is not drawn".into(),
        );
        return None;
    };
    let tags = match &v["tags_path"] {
        serde_json::Value::Null => None,
        serde_json::Value::String(s) => Some(PathBuf::from(s)),
        _ => {
            notes.push(
                "inputs.json: 'tags_path' is not a string: the recorded tag file is ignored".into(),
            );
            None
        }
    };
    Some((PathBuf::from(scenario), tags))
}

/// An error's message without the leading "PATH: " (for a note that names
/// the file itself).
pub(super) fn without_path(e: &Error, path: &Path) -> String {
    let text = e.to_string();
    let prefix = format!("{}: ", path.display());
    text.strip_prefix(&prefix).unwrap_or(&text).to_string()
}

/// Reads a JSON object file.
pub(super) fn read_json(path: &Path) -> Result<serde_json::Value> {
    let text = read_text(path, "JSON file")?;
    let v: serde_json::Value = serde_json::from_str(&text)
        .map_err(|e| Error::format(path, format!("invalid JSON: {e}")))?;
    if !v.is_object() {
        return Err(Error::format(path, "not a JSON object"));
    }
    Ok(v)
}

/// Checks that `v` holds the keys the report is made from, with their
/// types: `numbers` finite numbers (or null where `nullable`), `counts`
/// non-negative integers, `strings` strings.
pub(super) fn require(
    path: &Path,
    v: &serde_json::Value,
    numbers: &[&str],
    nullable: &[&str],
    counts: &[&str],
    strings: &[&str],
) -> Result<()> {
    let bad = |k: &str, what: &str| {
        Error::format(path, format!("'{k}' is {}, not {what}", describe(&v[k])))
    };
    for k in numbers {
        if !v[k].is_number() {
            return Err(bad(k, "a number"));
        }
    }
    for k in nullable {
        if !(v[k].is_number() || v[k].is_null()) {
            return Err(bad(k, "a number or null"));
        }
    }
    for k in counts {
        if !v[k].is_u64() {
            return Err(bad(k, "a whole number"));
        }
    }
    for k in strings {
        if !v[k].is_string() {
            return Err(bad(k, "a string"));
        }
    }
    Ok(())
}

fn describe(v: &serde_json::Value) -> String {
    match v {
        serde_json::Value::Null => "missing".into(),
        serde_json::Value::Bool(b) => format!("{b}"),
        serde_json::Value::Number(n) => format!("the number {n}"),
        serde_json::Value::String(s) => format!("the text {s:?}"),
        serde_json::Value::Array(_) => "a list".into(),
        serde_json::Value::Object(_) => "an object".into(),
    }
}

/// One example run of a Monte Carlo simulation, as plotted.
#[derive(Debug, Clone, Default)]
pub struct ExampleRun {
    /// Which run and why it is shown ("run 7, the median by maximum error").
    pub label: String,
    /// Its `errors.csv` rows.
    pub rows: Vec<ErrorRow>,
    /// Its tag passes.
    pub passes: Vec<PassRow>,
}

/// The runs shown of a Monte Carlo simulation: the median run by maximum
/// horizontal error (the lower median for an even count) and the worst,
/// as (run index, maximum) pairs from `summary.json`'s `per_run`.
pub fn example_runs(per_run_max: &[(u64, f64)]) -> Option<((u64, f64), (u64, f64))> {
    if per_run_max.is_empty() {
        return None;
    }
    let mut v = per_run_max.to_vec();
    v.sort_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)));
    Some((v[(v.len() - 1) / 2], v[v.len() - 1]))
}

/// `summary.json`'s per-run maxima.
pub fn per_run_max(summary: &serde_json::Value) -> Vec<(u64, f64)> {
    summary["per_run"]
        .as_array()
        .map(|a| {
            a.iter()
                .filter_map(|r| Some((r["run"].as_u64()?, r["max_horizontal_error_m"].as_f64()?)))
                .collect()
        })
        .unwrap_or_default()
}

/// The files an example run is written to (`errors_median_run.csv`, ...).
pub fn example_files(which: &str) -> (String, String) {
    (
        format!("errors_{which}_run.csv"),
        format!("tag_passes_{which}_run.csv"),
    )
}

/// Reads an example run's files when present.
pub(super) fn read_example(dir: &Path, which: &str, label: String) -> Result<Option<ExampleRun>> {
    let (e, p) = example_files(which);
    let (e, p) = (dir.join(e), dir.join(p));
    if !e.exists() {
        return Ok(None);
    }
    let rows = read_errors_csv(&e)?;
    let passes = if p.exists() {
        read_tag_passes_csv(&p)?
    } else {
        Vec::new()
    };
    Ok(Some(ExampleRun {
        label,
        rows,
        passes,
    }))
}

/// The plan's profile, or a note when a route plan lacks it.
pub(super) fn read_profile(
    dir: &Path,
    plan: &serde_json::Value,
    notes: &mut Vec<String>,
) -> Result<Vec<super::PlanProfileRow>> {
    let path = dir.join("profile.csv");
    if path.exists() {
        read_plan_profile_csv(&path)
    } else {
        if plan["coverage"].as_str() != Some("network") {
            notes.push(
                "profile.csv is missing: the predicted bound along the route is not plotted".into(),
            );
        }
        Ok(Vec::new())
    }
}

/// The overlay's tags from the table.
pub(super) fn map_tags(rows: &[TagRow]) -> Vec<MapTag> {
    rows.iter()
        .filter_map(|r| {
            let m = crate::tags::Mounting::parse(&r.mounting)?;
            let mut info = format!("{} · {}", r.tag_id, r.mounting.replace('_', " "));
            if !r.road.is_empty() {
                info.push_str(&format!(" · road {}", r.road));
            }
            if let Some(c) = r.chainage_m {
                info.push_str(&format!(" · chainage {c:.1} m"));
            }
            if !r.reason.is_empty() {
                info.push_str(&format!(" · {}", r.reason));
            }
            Some(MapTag {
                lat_lon: r.lat_lon,
                mounting: m,
                info,
            })
        })
        .collect()
}

/// An empty overlay scaled to `requirement_m`.
pub(super) fn overlay(requirement_m: Option<f64>) -> MapOverlay {
    MapOverlay {
        requirement_m,
        ..Default::default()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `plan.json`'s tags: a tag of the table gets the plan's reason and
    /// road name; an installed tag the table leaves out is appended (its
    /// reason "installed already" when the plan gives none); a tag without
    /// a position is skipped.
    #[test]
    fn plan_tags_are_merged_into_the_table() {
        let plan = serde_json::json!({"tags": [
            {"tag_id": "T1", "lat": 60.1, "lon": 24.9, "reason": "gap", "road_name": "Mannerheimintie"},
            {"tag_id": "E1", "lat": 60.2, "lon": 24.8, "existing": true, "mounting": "ceiling",
             "road_id": "r7", "road_chainage_m": 12.5, "height_m": 4.0},
            {"tag_id": "E2", "lat": 60.3, "existing": true},
            {"tag_id": "E3", "lat": 60.4, "lon": 24.7, "existing": true, "reason": "kept"},
        ]});
        let mut rows = vec![TagRow {
            tag_id: "T1".into(),
            lat_lon: [60.1, 24.9],
            road: "r1".into(),
            ..Default::default()
        }];
        merge_plan_tags(&mut rows, &plan);
        let ids: Vec<&str> = rows.iter().map(|r| r.tag_id.as_str()).collect();
        assert_eq!(ids, ["T1", "E1", "E3"]);
        assert_eq!(rows[0].reason, "gap");
        assert_eq!(rows[0].road, "r1 (Mannerheimintie)");
        assert!(!rows[0].existing);
        let e1 = &rows[1];
        assert!(e1.existing);
        assert_eq!(e1.reason, "installed already");
        assert_eq!(
            (
                e1.mounting.as_str(),
                e1.road.as_str(),
                e1.chainage_m,
                e1.height_m
            ),
            ("ceiling", "r7", Some(12.5), Some(4.0))
        );
        assert_eq!(rows[2].reason, "kept");
        // Without tags.csv the report takes the plan's own list.
        let own: Vec<TagRow> = plan["tags"]
            .as_array()
            .unwrap()
            .iter()
            .filter_map(TagRow::from_plan_tag)
            .collect();
        assert_eq!(own.len(), 3);
        assert_eq!(own[0].reason, "gap");
        assert!(own[1].existing && own[1].reason.is_empty());
    }
}
