//! RFID tags in a simulation: the tag list (from the scenario's `[[tag]]`
//! entries or a `tags.csv`), when the vehicle passes each tag within its
//! mounting's read geometry (found once from the truth), and per run whether
//! a pass is read and with what fix error (PAPERS.md §1.1).
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

use super::run::TruthSource;
use crate::error::{Error, Result};
use crate::sensors::rng::normal;
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use rustc_hash::FxHashMap;
use std::path::Path;

pub use crate::tags::Mounting;

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

/// RFID reader settings (from `[rfid]`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RfidModel {
    /// Probability that a passed tag is read.
    pub read_probability: f64,
    /// Read probability by mounting (road surface, roadside, ceiling),
    /// overriding `read_probability` where given.
    pub read_probability_by_mounting: [Option<f64>; 3],
    /// Lane width D (m).
    pub lane_width_m: f64,
    /// Vehicle width d (m).
    pub vehicle_width_m: f64,
    /// Lateral reader-to-tag distance x of roadside tags (m).
    pub roadside_distance_m: f64,
    /// Angle θ at which a roadside tag first answers (rad).
    pub roadside_angle: f64,
    /// Read time t0 (s).
    pub read_time_s: f64,
    /// Largest lateral distance from the path at which a roadside tag's
    /// stored point is still read (m).
    pub roadside_range_m: f64,
    /// σ of the road-surface fix (m), capped at 0.5 m.
    pub road_surface_sigma_m: f64,
    /// σ of the ceiling fix (m), capped at 0.3 m.
    pub ceiling_sigma_m: f64,
    /// σ of a tag's stored height (m).
    pub height_sigma_m: f64,
}

impl Default for RfidModel {
    fn default() -> Self {
        Self {
            read_probability: 1.0,
            read_probability_by_mounting: [None; 3],
            lane_width_m: 3.75,
            vehicle_width_m: 2.5,
            roadside_distance_m: 5.63,
            roadside_angle: 15f64.to_radians(),
            read_time_s: 0.02,
            roadside_range_m: 10.0,
            road_surface_sigma_m: 0.2,
            ceiling_sigma_m: 0.1,
            height_sigma_m: 0.1,
        }
    }
}

impl RfidModel {
    /// The probability that a pass by a tag of mounting `m` is read.
    pub fn read_probability_of(&self, m: Mounting) -> f64 {
        let i = match m {
            Mounting::RoadSurface => 0,
            Mounting::Roadside => 1,
            Mounting::Ceiling => 2,
        };
        self.read_probability_by_mounting[i].unwrap_or(self.read_probability)
    }

    /// The model for a tag whose lane width is known (`None`: unchanged).
    pub fn with_lane_width(&self, lane_width_m: Option<f64>) -> Self {
        let mut m = *self;
        if let Some(w) = lane_width_m {
            m.lane_width_m = w;
        }
        m
    }

    /// Half-width of the lateral band within which a tag is read (m).
    pub fn read_half_width(&self, m: Mounting) -> f64 {
        match m {
            Mounting::RoadSurface => 0.5 * self.vehicle_width_m,
            Mounting::Roadside => self.roadside_range_m,
            Mounting::Ceiling => 0.5 * self.lane_width_m,
        }
    }

    /// Half-width of the vehicle's lateral place over a road-surface tag (m):
    /// half the lane's free width (D − d)/2, at most 0.4 m.
    pub fn road_surface_lateral_m(&self) -> f64 {
        (0.5 * (self.lane_width_m - self.vehicle_width_m)).clamp(0.0, 0.4)
    }

    /// The filter's fix covariance (along-track σ, cross-track σ) for a
    /// mounting at speed `v` (m/s).
    pub fn fix_sigmas(&self, m: Mounting, v: f64) -> (f64, f64) {
        match m {
            Mounting::RoadSurface => {
                let s = self.road_surface_sigma_m.min(0.5);
                (
                    s.max(0.05),
                    (self.road_surface_lateral_m() / 3f64.sqrt()).max(0.05),
                )
            }
            Mounting::Ceiling => {
                let s = self.ceiling_sigma_m.min(0.3);
                (s.max(0.05), s.max(0.05))
            }
            Mounting::Roadside => {
                let dy =
                    self.roadside_distance_m * self.roadside_angle.tan() - v * self.read_time_s;
                let dx = 0.5 * (self.lane_width_m - self.vehicle_width_m).max(0.0);
                // dy is a bias at a given speed: taken as a 1σ error; dx is
                // the half-width of a uniform spread (σ = dx/√3).
                (dy.abs().max(0.2), (dx / 3f64.sqrt()).max(0.1))
            }
        }
    }
}

/// A pass of the vehicle by a tag (from the truth, the same in every run).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TagPass {
    /// Index of the tag.
    pub tag: usize,
    /// Time the vehicle is abeam the tag's physical reference point (s).
    pub t_abeam: f64,
    /// Speed then (m/s).
    pub speed_mps: f64,
    /// Lateral distance of the reference point from the path, right positive (m).
    pub lateral_m: f64,
    /// Heading then (forward unit vector east, north).
    pub forward_en: [f64; 2],
}

/// One read in a run: the measurement to give the filter.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TagRead {
    /// Index of the tag.
    pub tag: usize,
    /// Index of the pass (in the `passes` given to [`draw_reads`]).
    pub pass: usize,
    /// Read time (s).
    pub t: f64,
    /// Reported latitude, longitude (rad).
    pub lat: f64,
    /// Reported longitude (rad).
    pub lon: f64,
    /// Reported height (m).
    pub height_m: Option<f64>,
    /// Mounting.
    pub mounting: Mounting,
}

/// Finds every pass of the vehicle by a tag within the tag's read geometry:
/// the moment the tag's physical reference point goes from ahead of the
/// vehicle to behind it (sampled at about 10 Hz, interpolated).
pub fn find_passes(
    truth: &TruthSource,
    cap_s: f64,
    tags: &[Tag],
    rfid: &RfidModel,
) -> Vec<TagPass> {
    if tags.is_empty() {
        return vec![];
    }
    const CELL_DEG: f64 = 0.0005;
    // Physical positions.
    let phys: Vec<(f64, f64)> = tags
        .iter()
        .map(|t| {
            let (rm, rn) = crate::geodesy::radii(t.lat);
            (
                t.lat - t.survey_error_m[1] / rm,
                t.lon - t.survey_error_m[0] / (rn * t.lat.cos()),
            )
        })
        .collect();
    let lon_cell = |lat: f64| CELL_DEG / lat.cos().max(0.05);
    let mut grid: FxHashMap<(i64, i64), Vec<usize>> = FxHashMap::default();
    for (i, &(la, lo)) in phys.iter().enumerate() {
        let key = (
            (la.to_degrees() / CELL_DEG).floor() as i64,
            (lo.to_degrees() / lon_cell(la)).floor() as i64,
        );
        grid.entry(key).or_default().push(i);
    }
    let mut last: Vec<(u64, f64)> = vec![(u64::MAX, 0.0); tags.len()];
    let mut passes = Vec::new();
    let mut k = 0u64;
    let mut t_prev = 0.0;
    for avp in truth.samples().take_while(|a| a.t <= cap_s).step_by(10) {
        k += 1;
        let s = &avp.state;
        let f = s.q.transform_vector(&[0.0, 1.0, 0.0].into());
        let fh = f[0].hypot(f[1]);
        if fh < 1e-6 {
            t_prev = avp.t;
            continue;
        }
        let fwd = [f[0] / fh, f[1] / fh];
        let speed = s.v[0].hypot(s.v[1]);
        let (rm, rn) = crate::geodesy::radii(s.lat);
        let cl = s.lat.cos();
        let ci = (s.lat.to_degrees() / CELL_DEG).floor() as i64;
        let cj = (s.lon.to_degrees() / lon_cell(s.lat)).floor() as i64;
        for di in -1..=1 {
            for dj in -1..=1 {
                let Some(list) = grid.get(&(ci + di, cj + dj)) else {
                    continue;
                };
                for &i in list {
                    let (la, lo) = phys[i];
                    let e = (lo - s.lon) * rn * cl;
                    let n = (la - s.lat) * rm;
                    let along = e * fwd[0] + n * fwd[1];
                    let lateral = e * fwd[1] - n * fwd[0];
                    let (lk, ls) = last[i];
                    if lk == k - 1 && ls > 0.0 && along <= 0.0 && speed > 0.1 {
                        let w = ls / (ls - along);
                        let t_abeam = t_prev + w * (avp.t - t_prev);
                        if lateral.abs() <= rfid.read_half_width(tags[i].mounting) {
                            passes.push(TagPass {
                                tag: i,
                                t_abeam,
                                speed_mps: speed,
                                lateral_m: lateral,
                                forward_en: fwd,
                            });
                        }
                    }
                    last[i] = (k, along);
                }
            }
        }
        t_prev = avp.t;
    }
    passes.sort_by(|a, b| a.t_abeam.total_cmp(&b.t_abeam));
    passes
}

/// The reads of one run: each pass read with the read probability, with
/// the mounting's timing and lateral errors.
pub fn draw_reads(
    passes: &[TagPass],
    tags: &[Tag],
    rfid: &RfidModel,
    rng: &mut ChaCha8Rng,
) -> Vec<TagRead> {
    let mut out = Vec::with_capacity(passes.len());
    for (pass, p) in passes.iter().enumerate() {
        let u: f64 = rng.random();
        // Draw the errors whether or not the read succeeds, so that the read
        // probability does not shift other reads' errors.
        let z1 = normal(rng);
        let u2: f64 = rng.random();
        let tag = &tags[p.tag];
        let rfid = &rfid.with_lane_width(tag.lane_width_m);
        if u >= rfid.read_probability_of(tag.mounting) {
            continue;
        }
        let v = p.speed_mps.max(0.1);
        // Time of the read relative to abeam, and the lateral offset of the
        // reported point from the vehicle (m, right positive).
        let (dt, lateral) = match tag.mounting {
            Mounting::RoadSurface => {
                // Along-track timing error and the vehicle's lateral place
                // over the tag (uniform within the lateral half-width), the
                // whole fix error capped at 0.5 m.
                let e = rfid.road_surface_sigma_m * z1;
                let l = rfid.road_surface_lateral_m() * (2.0 * u2 - 1.0);
                let n = e.hypot(l);
                let k = if n > 0.5 { 0.5 / n } else { 1.0 };
                (k * e / v, k * l)
            }
            Mounting::Ceiling => {
                let e = (rfid.ceiling_sigma_m * z1).clamp(-0.3, 0.3);
                (e / v, 0.0)
            }
            Mounting::Roadside => {
                let dx =
                    0.5 * (rfid.lane_width_m - rfid.vehicle_width_m).max(0.0) * (2.0 * u2 - 1.0);
                let x = (rfid.roadside_distance_m - dx).max(0.0);
                let lead = x * rfid.roadside_angle.tan();
                (-lead / v + rfid.read_time_s, dx)
            }
        };
        // The reported point: the stored coordinates, shifted laterally by
        // the vehicle's offset in its lane (the stored point is the lane centre).
        let (rm, rn) = crate::geodesy::radii(tag.lat);
        let [fe, fnn] = p.forward_en;
        let (re, rn_) = (fnn, -fe);
        let lat = tag.lat + lateral * rn_ / rm;
        let lon = tag.lon + lateral * re / (rn * tag.lat.cos());
        out.push(TagRead {
            tag: p.tag,
            pass,
            t: p.t_abeam + dt,
            lat,
            lon,
            height_m: tag.height_m,
            mounting: tag.mounting,
        });
    }
    out.sort_by(|a, b| a.t.total_cmp(&b.t));
    out
}

/// Reads a tags CSV (header row; `tag_id,lat,lon,mounting` required,
/// `height_m` optional, other columns ignored).
pub fn load_tags_csv(path: &Path) -> Result<Vec<Tag>> {
    let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
    parse_tags_csv(path, &text)
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

    #[test]
    fn draw_reads_uses_the_mounting_read_probability() {
        use rand::SeedableRng;
        let tag = |m| Tag {
            id: "t".into(),
            lat: 0.0,
            lon: 0.0,
            height_m: None,
            mounting: m,
            survey_error_m: [0.0; 2],
            lane_width_m: None,
        };
        let tags = vec![tag(Mounting::Roadside), tag(Mounting::Ceiling)];
        let mut m = RfidModel {
            read_probability: 0.5,
            ..RfidModel::default()
        };
        m.read_probability_by_mounting[2] = Some(1.0);
        let pass = |i: usize| TagPass {
            tag: i,
            t_abeam: i as f64,
            speed_mps: 10.0,
            lateral_m: 0.0,
            forward_en: [0.0, 1.0],
        };
        let passes: Vec<TagPass> = (0..2000).map(|i| pass(i % 2)).collect();
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let reads = draw_reads(&passes, &tags, &m, &mut rng);
        let ceiling = reads
            .iter()
            .filter(|r| r.mounting == Mounting::Ceiling)
            .count();
        let roadside = reads.len() - ceiling;
        // Every ceiling pass read; roadside about half of 1000 (±5σ = ±79).
        assert_eq!(ceiling, 1000);
        assert!((roadside as f64 - 500.0).abs() < 79.0, "{roadside}");
    }
}
