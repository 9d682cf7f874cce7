//! The rows and records a simulation run produces: error rows at the output
//! interval, tag reads and passes, one run's result, and the recorder that
//! keeps a row every output interval.

use crate::geodesy::radii;
use crate::nav::NavState;
use crate::trajectory::Avp;

/// Navigation error at one output time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ErrorRow {
    /// Time (s).
    pub t_s: f64,
    /// Distance travelled (m).
    pub distance_m: f64,
    /// East error, estimate minus truth (m).
    pub east_m: f64,
    /// North error (m).
    pub north_m: f64,
    /// Up error (m).
    pub up_m: f64,
    /// Horizontal error (m).
    pub horizontal_m: f64,
    /// Filter 1σ east (m); NaN without a filter.
    pub sigma_east_m: f64,
    /// Filter 1σ north (m); NaN without a filter.
    pub sigma_north_m: f64,
    /// Filter 1σ up (m); NaN without a filter.
    pub sigma_up_m: f64,
    /// The filter's horizontal 95 % bound (m) from its full east–north
    /// covariance, correlation included ([`super::bound::bound95`]); NaN without
    /// a filter. 2.4477·max(σ_E, σ_N) is below it wherever east and north
    /// are correlated (a road neither east–west nor north–south).
    pub bound95_m: f64,
    /// Horizontal normalised estimation error squared e^T P^{-1} e (2 dof);
    /// NaN without a filter.
    pub nees_h: f64,
}

/// What happened to one tag read in a run.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct TagEvent {
    /// The tag.
    pub tag_id: String,
    /// Read time (s).
    pub t_s: f64,
    /// Whether the filter accepted the fix.
    pub accepted: bool,
    /// Its normalised innovation squared.
    pub nis: f64,
}

/// A pass of the vehicle by a tag in one run, and what came of it.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct PassRecord {
    /// Time the vehicle is abeam the tag (s).
    pub t_s: f64,
    /// Distance driven then (m).
    pub distance_m: f64,
    /// The tag.
    pub tag_id: String,
    /// Its mounting.
    pub mounting: crate::tags::Mounting,
    /// Whether the reader read it (false: missed, or RFID aiding off).
    pub read: bool,
    /// Time of the read (s), if read.
    pub read_t_s: Option<f64>,
    /// Whether the filter accepted the fix (None: not read, or read after the run ended).
    pub accepted: Option<bool>,
    /// The fix's normalised innovation squared, if the filter saw it.
    pub nis: Option<f64>,
}

/// The rows of one run.
#[derive(Debug, Clone, PartialEq)]
pub struct RunResult {
    /// Monte Carlo run index.
    pub run: u64,
    /// Error rows at the output interval.
    pub rows: Vec<ErrorRow>,
    /// Tag reads and the filter's verdicts (integrated mode).
    pub tag_events: Vec<TagEvent>,
    /// Every pass by a tag, read or missed, in time order (integrated mode).
    pub tag_passes: Vec<PassRecord>,
    /// Update counts (integrated mode).
    pub counts: Option<crate::nav::integrated::UpdateCounts>,
    /// What the map-matching feed did (integrated mode with `aiding.map_matching`).
    pub map_feed: Option<super::map_feed::FeedCounts>,
    /// The filter's odometer calibration at the end of the run beside the
    /// simulated one (integrated mode with odometer aiding): scale-factor
    /// error (ratio), pitch and yaw misalignment (rad), each as (truth,
    /// estimate, filter σ).
    pub calibration: Option<[[f64; 3]; 3]>,
    /// Run 0's odometer calibration at the output interval, at the times of
    /// its error rows (`calibration.csv`); empty for the other runs, which
    /// keep only their end state ([`Self::calibration`]), and without
    /// odometer aiding.
    pub calibration_rows: Vec<CalibrationRow>,
}

/// The filter's odometer calibration at one output time beside the
/// simulated one: scale-factor error (ratio), pitch and yaw misalignment
/// (rad), each as (truth, estimate, filter σ).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CalibrationRow {
    /// Time (s).
    pub t_s: f64,
    /// Distance driven (m).
    pub distance_m: f64,
    /// Scale factor, pitch and yaw misalignment: (truth, estimate, σ).
    pub states: [[f64; 3]; 3],
}

/// Estimate minus truth in local metres (east, north, up).
#[inline]
fn error_enu(lat: f64, lon: f64, h: f64, truth: &NavState) -> [f64; 3] {
    let (rm, rn) = radii(truth.lat);
    [
        (lon - truth.lon) * (rn + truth.h) * truth.lat.cos(),
        (lat - truth.lat) * (rm + truth.h),
        h - truth.h,
    ]
}

pub(super) type Cov3 = Option<[[f64; 3]; 3]>;

impl RunResult {
    /// A run with no samples.
    pub(super) fn empty(run: u64) -> Self {
        RunResult {
            run,
            rows: vec![],
            tag_events: vec![],
            tag_passes: vec![],
            counts: None,
            map_feed: None,
            calibration: None,
            calibration_rows: vec![],
        }
    }
}

/// Keeps a row every `every` samples, and the last sample's row at the end.
pub(super) struct Recorder {
    pub(super) every: u64,
    pub(super) rows: Vec<ErrorRow>,
    pub(super) pending: Option<(Avp, f64, f64, f64, Cov3)>,
}

impl Recorder {
    fn row(avp: &Avp, lat: f64, lon: f64, h: f64, cov: Cov3) -> ErrorRow {
        let e = error_enu(lat, lon, h, &avp.state);
        let (se, sn, su, nees, b95) = match cov {
            Some(c) => {
                let det = c[0][0] * c[1][1] - c[0][1] * c[1][0];
                let nees = if det > 0.0 {
                    (e[0] * e[0] * c[1][1] - 2.0 * e[0] * e[1] * c[0][1] + e[1] * e[1] * c[0][0])
                        / det
                } else {
                    f64::NAN
                };
                let b95 = super::bound::bound95(&c);
                (c[0][0].sqrt(), c[1][1].sqrt(), c[2][2].sqrt(), nees, b95)
            }
            None => (f64::NAN, f64::NAN, f64::NAN, f64::NAN, f64::NAN),
        };
        ErrorRow {
            t_s: avp.t,
            distance_m: avp.distance_m,
            east_m: e[0],
            north_m: e[1],
            up_m: e[2],
            horizontal_m: e[0].hypot(e[1]),
            sigma_east_m: se,
            sigma_north_m: sn,
            sigma_up_m: su,
            bound95_m: b95,
            nees_h: nees,
        }
    }

    #[inline]
    pub(super) fn record(&mut self, k: u64, avp: &Avp, lat: f64, lon: f64, h: f64) {
        self.record_cov(k, avp, lat, lon, h, None)
    }

    #[inline]
    pub(super) fn due(&self, k: u64) -> bool {
        k % self.every == 0
    }

    #[inline]
    pub(super) fn record_cov(&mut self, k: u64, avp: &Avp, lat: f64, lon: f64, h: f64, cov: Cov3) {
        if self.due(k) {
            self.rows.push(Self::row(avp, lat, lon, h, cov));
            self.pending = None;
        } else {
            self.pending = Some((*avp, lat, lon, h, cov));
        }
    }

    pub(super) fn finish(mut self) -> Vec<ErrorRow> {
        self.flush();
        self.rows
    }

    /// Records the pending row (the last sample's, at the end of a run).
    pub(super) fn flush(&mut self) {
        if let Some((avp, lat, lon, h, cov)) = self.pending.take() {
            self.rows.push(Self::row(&avp, lat, lon, h, cov));
        }
    }
}
