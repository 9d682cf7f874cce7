//! RFID tags in a simulation: the tag list (from the scenario's `[[tag]]`
//! entries or a `tags.csv`) and the RFID model: read geometry, read
//! probability and fix error of each mounting (PAPERS.md §1.1). When the
//! vehicle passes each tag and which passes are read: `super::passes`.
//!
//! Fix error models:
//! - road surface (reader under the vehicle): the read happens while the
//!   reader is over the tag; the along-track timing error is normal with σ
//!   `road_surface_sigma_m`, capped at 0.5 m; read when the vehicle's centre
//!   line passes within half the vehicle width;
//! - roadside (reader on the side, tag on a post `roadside_distance_m` = x from
//!   the lane centre, storing the lane-centre point abeam): the tag answers
//!   when the reader sees it at angle θ, x tan θ before abeam, and the read ends
//!   t0 later: the vehicle is dy = x tan θ − v t0 behind the stored point; the
//!   vehicle's lateral place in the lane is uniform within dx = (D − d)/2;
//! - ceiling (reader in the tunnel roof reading a roof tag): like the road
//!   surface with σ `ceiling_sigma_m`, capped at 0.3 m.
//!
//! A tag's stored coordinates may differ from where it physically is
//! (`survey_error_m`): a misplaced or rogue tag, for the filter's gate to catch.

use crate::error::{Error, Result};
use std::path::Path;

pub use crate::tags::{Mounting, RfidModel};

/// A tag as the navigator knows it, and where it really is.
#[derive(Debug, Clone, PartialEq)]
pub struct Tag {
    /// Identifier.
    pub id: String,
    /// Stored latitude (rad).
    pub lat: f64,
    /// Stored longitude (rad).
    pub lon: f64,
    /// Stored height (m), if any.
    pub height_m: Option<f64>,
    /// Mounting.
    pub mounting: Mounting,
    /// Stored minus physical position, east and north (m).
    pub survey_error_m: [f64; 2],
    /// Width of the lane the tag serves (m), when known (the planner takes
    /// it from the road's OSM `width`/`lanes` or class); else `[rfid]`'s.
    pub lane_width_m: Option<f64>,
}

/// Largest tag file read (bytes): 256 MiB, about two million tags.
pub const MAX_TAGS_CSV_BYTES: u64 = 256 << 20;

/// Reads a tags CSV (header row; `tag_id,lat,lon,mounting` required,
/// `height_m` optional, other columns ignored), up to
/// [`MAX_TAGS_CSV_BYTES`].
pub fn load_tags_csv(path: &Path) -> Result<Vec<Tag>> {
    let text = crate::fsio::read_text_limited(path, MAX_TAGS_CSV_BYTES, "tag file")?;
    parse_tags_csv(path, &text)
}

/// Refuses a tag file (`path`, holding `tags`) that shares a tag id with
/// the `[[tag]]`s of the scenario `scn`: a run simulates both, and their
/// reads and passes could not be told apart (in `tag_passes.csv`, in a
/// plan's validation).
pub fn refuse_ids_of_scenario_tags(
    path: &Path,
    tags: &[Tag],
    scn: &crate::scenario::Scenario,
) -> Result<()> {
    match tags
        .iter()
        .find(|t| scn.tags().iter().any(|s| s.id == t.id))
    {
        Some(t) => Err(Error::format(
            path,
            format!(
                "tag_id \"{}\" is also a [[tag]] of {}: tag ids must be unique",
                t.id,
                scn.path.display()
            ),
        )),
        None => Ok(()),
    }
}

/// Parses tags CSV text; errors name the file, the line and the problem.
pub fn parse_tags_csv(path: &Path, text: &str) -> Result<Vec<Tag>> {
    let err = |line: u64, msg: String| Error::format(path, format!("line {line}: {msg}"));
    // Lines starting with '#' are metadata (Waymark's own tags.csv starts with
    // them); fields may be quoted (RFC 4180).
    let mut reader = csv::ReaderBuilder::new()
        .comment(Some(b'#'))
        .trim(csv::Trim::All)
        .flexible(true)
        .from_reader(text.trim_start_matches('\u{feff}').as_bytes());
    let header = reader
        .headers()
        .map_err(|e| Error::format(path, format!("unreadable header: {e}")))?
        .clone();
    if header.iter().all(|c| c.is_empty()) {
        return Err(Error::format(
            path,
            "empty file: expected a header row with tag_id,lat,lon,mounting",
        ));
    }
    let header_line = header.position().map_or(1, |p| p.line());
    let find = |name: &str| header.iter().position(|c| c == name);
    let (Some(ci), Some(cla), Some(clo), Some(cm)) =
        (find("tag_id"), find("lat"), find("lon"), find("mounting"))
    else {
        return Err(err(
            header_line,
            format!(
                "header must have tag_id, lat, lon and mounting columns, got \"{}\"",
                header.iter().collect::<Vec<_>>().join(",")
            ),
        ));
    };
    let ch = find("height_m");
    let mut tags = Vec::new();
    let mut seen = rustc_hash::FxHashSet::default();
    for record in reader.records() {
        let f = record.map_err(|e| {
            let line = e.position().map_or(0, |p| p.line());
            err(line, format!("unreadable row: {e}"))
        })?;
        let ln = f.position().map_or(0, |p| p.line());
        if f.iter().all(|c| c.is_empty()) {
            continue;
        }
        if f.len() < header.len() {
            return Err(err(
                ln,
                format!("{} fields, the header has {}", f.len(), header.len()),
            ));
        }
        let id = f[ci].to_string();
        if id.is_empty() {
            return Err(err(ln, "empty tag_id".into()));
        }
        if !seen.insert(id.clone()) {
            return Err(err(ln, format!("duplicate tag_id \"{id}\"")));
        }
        let num = |c: usize, name: &str, lo: f64, hi: f64| -> Result<f64> {
            let x: f64 = f[c]
                .parse()
                .map_err(|_| err(ln, format!("{name} \"{}\" is not a number", &f[c])))?;
            if !(x.is_finite() && x >= lo && x <= hi) {
                return Err(err(ln, format!("{name} {x} is outside [{lo}, {hi}]")));
            }
            Ok(x)
        };
        let lat = num(cla, "lat", -90.0, 90.0)?;
        let lon = num(clo, "lon", -180.0, 180.0)?;
        let height_m = match ch {
            Some(c) if !f[c].is_empty() => Some(num(c, "height_m", -1000.0, 10_000.0)?),
            _ => None,
        };
        let mounting = Mounting::parse(&f[cm]).ok_or_else(|| {
            err(
                ln,
                format!(
                    "mounting \"{}\" is not one of road_surface, roadside, ceiling",
                    &f[cm]
                ),
            )
        })?;
        tags.push(Tag {
            id,
            lat: lat.to_radians(),
            lon: lon.to_radians(),
            height_m,
            mounting,
            survey_error_m: [0.0, 0.0],
            lane_width_m: None,
        });
    }
    Ok(tags)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn read_probability_by_mounting_overrides_the_common_one() {
        let mut m = RfidModel {
            read_probability: 0.977,
            ..RfidModel::default()
        };
        m.read_probability_by_mounting[2] = Some(0.999);
        assert_eq!(m.read_probability_of(Mounting::Ceiling), 0.999);
        assert_eq!(m.read_probability_of(Mounting::Roadside), 0.977);
        assert_eq!(m.read_probability_of(Mounting::RoadSurface), 0.977);
    }

    #[test]
    fn lane_width_widens_the_roadside_cross_track_error() {
        // (D − d)/2 with d = 2.5 m: 0.25 m on a 3 m lane, 0.75 m on a 4 m lane.
        let m = RfidModel::default();
        let (_, narrow) = m
            .with_lane_width(Some(3.0))
            .fix_sigmas(Mounting::Roadside, 10.0);
        let (_, wide) = m
            .with_lane_width(Some(4.0))
            .fix_sigmas(Mounting::Roadside, 10.0);
        assert!((narrow - 0.25 / 3f64.sqrt()).abs() < 1e-12, "{narrow}");
        assert!((wide - 0.75 / 3f64.sqrt()).abs() < 1e-12, "{wide}");
        assert_eq!(m.with_lane_width(None), m);
    }
}
