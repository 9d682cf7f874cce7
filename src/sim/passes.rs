//! When the vehicle passes each tag within its mounting's read geometry
//! (found once from the truth, the same in every run), and per run whether a
//! pass is read and with what fix error (the models of [`super::tags`]).

use super::tags::{Mounting, RfidModel, Tag};
use super::truth::TruthSource;
use crate::sensors::rng::normal;
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use rustc_hash::FxHashMap;

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
                // over the tag (the truth's, or uniform within the lateral
                // half-width), the whole fix error capped at 0.5 m.
                let e = rfid.road_surface_sigma_m * z1;
                let l = if rfid.lateral_from_truth {
                    -p.lateral_m
                } else {
                    rfid.road_surface_lateral_m() * (2.0 * u2 - 1.0)
                };
                let n = e.hypot(l);
                let k = if n > 0.5 { 0.5 / n } else { 1.0 };
                (k * e / v, k * l)
            }
            Mounting::Ceiling => {
                let e = (rfid.ceiling_sigma_m * z1).clamp(-0.3, 0.3);
                (e / v, 0.0)
            }
            Mounting::Roadside => {
                // The vehicle's offset towards the post from the lane centre:
                // the truth's, or uniform within the lane's free width.
                let dx = if rfid.lateral_from_truth {
                    -p.lateral_m
                } else {
                    0.5 * (rfid.lane_width_m - rfid.vehicle_width_m).max(0.0) * (2.0 * u2 - 1.0)
                };
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

#[cfg(test)]
mod tests {
    use super::*;

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
