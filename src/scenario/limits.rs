//! Size limits of a scenario, checked before any work allocates memory or
//! time in proportion to them: one error naming the field and the limit
//! (README, "Limits and reliability"). Durations, rates and the rows a
//! simulation keeps are checked where they are known: the IMU rate and
//! the motion commands' 30-day limit in validation and the motion compiler,
//! the drive's length and the kept rows in `sim::limits`; a network plan's
//! candidate sites once its map is loaded ([`check_network_candidates`]);
//! the memory of a map route's truth from its waypoints when the scenario
//! is read, then from the routed route before its truth is built
//! ([`check_route_memory`]).

use super::check::{short_number, Check};
use super::schema::ScenarioFile;
use super::sections::LANE_PATH_SPACING_M;
use super::Scenario;
use crate::elevation::PROFILE_STEP_M;
use crate::error::{Error, Result};
use crate::network::RoadNetwork;
use crate::route::{Route, RouteSpan, RouteVertex, SnappedWaypoint};
use crate::trajectory::RoutePlan;

/// Largest scenario file read (bytes): a scenario with thousands of
/// `[[tag]]` entries is well under 1 MiB.
pub const MAX_SCENARIO_BYTES: u64 = 16 << 20;

/// Most Monte Carlo runs of one simulation or plan validation
/// (`planner.validation_runs`, `simulate --runs`, `plan --runs`).
pub const MAX_RUNS: u64 = 100_000;

/// Most consecutive missed reads a plan may tolerate
/// (`planner.tolerate_missed_reads`): the route planner searches windows of
/// the last k + 1 tags, whose number grows as (sites within reach)^k; on
/// the demo's 4 km route k = 2 takes 3 s and 0.1 GB, k = 3 45 s and 1.4 GB,
/// and k = 4 did not finish within 2 minutes.
pub const MAX_TOLERATED_MISSED_READS: u64 = 3;

/// Most refinements of a route plan's reaches (`planner.refine_iterations`;
/// each is a covariance pass and a placement).
pub const MAX_REFINE_ITERATIONS: u64 = 100;

/// Most `[map] elevation` files (tiles). Their pixels together are limited
/// by [`crate::elevation::MAX_DEM_PIXELS`], checked from each file's header
/// before its raster is decoded.
pub const MAX_ELEVATION_FILES: usize = 64;

/// Largest gyro error term (°/h: `gyro_bias_dph`, `gyro_bias_instability_dph`,
/// `gyro_bias_random_dph`): 1000 °/s, beyond any gyro's measurement range.
/// At this limit the simulation and the planner's covariance analysis stay
/// finite (measured: a 1 h free-inertial drive; the demo plan reports the
/// requirement infeasible); at 1e300 °/h they did not.
pub const MAX_GYRO_ERROR_DPH: f64 = 3.6e6;

/// Largest accelerometer error term (µg: `accel_bias_ug`,
/// `accel_bias_instability_ug`, `accel_bias_random_ug`, `accel_vrw_ugprhz`):
/// 10 g.
pub const MAX_ACCEL_ERROR_UG: f64 = 1e7;

/// Largest gyro angle random walk (°/√h): 60 °/√h is 1 °/√s.
pub const MAX_GYRO_ARW_DPRH: f64 = 3600.0;

/// Largest `[map] geometry_error_m` (m, 1σ per horizontal axis of the
/// map's road geometry). OpenStreetMap roads are about 6 m off on average
/// (Haklay 2010: the default σ of 4.8 m), its worst areas tens of metres.
/// At 100 m a road is drawn on the next street of a city block (on the
/// Helsinki map-matching drive 90 % of the matched points were then on a
/// wrong road): beyond it the model is no longer a map with errors but a
/// different map. At 1e308 the error field overflowed and map matching fed
/// no point, silently.
pub const MAX_MAP_GEOMETRY_ERROR_M: f64 = 100.0;

/// Longest `[map] geometry_error_correlation_m` (m): 1000 km, more than any
/// map Waymark loads spans, so at this length the error is already one
/// rigid shift of the whole map. At 1e308 the field's frequencies
/// underflowed and map matching reported an across-road error of 0.
pub const MAX_MAP_ERROR_CORRELATION_M: f64 = 1e6;

/// Largest ratio of `geometry_error_m` to `geometry_error_correlation_m`.
/// The error field's gradient has an RMS of σ/L per axis and peaks at about
/// four times that over a map; where it reaches 1 the erroneous map folds
/// roads over each other, and `sim::map_error`'s inversion (a fixed-point
/// iteration) no longer converges. OpenStreetMap-like maps are at 0.024.
pub const MAX_MAP_ERROR_GRADIENT: f64 = 0.25;

/// Largest |`route[0].start.heading_deg`|: one turn either way; a heading
/// beyond it is a typo (1e308 was taken, its sine and cosine arbitrary).
pub const MAX_HEADING_DEG: f64 = 360.0;

/// Largest |`[[tag]] survey_error_m`| per axis (m): the offset of a tag's
/// stored place from its physical one, a misplaced or rogue tag (the
/// bundled `misplaced-tag.toml` has one 2.6 km away). 100 km is a tag of
/// another town; the offset is applied with the local radii of curvature,
/// which stays accurate to a fraction of a per cent there, and the filter's
/// gate rejects such a tag as it does one 2.6 km away. At 1e308 the stored
/// place was infinite.
pub const MAX_SURVEY_ERROR_M: f64 = 1e5;

/// Largest barometer error term (m: |`[baro] initial_bias_m`|,
/// `bias_drift_m`, `noise_m`). An uncalibrated barometric altimeter is off
/// by the day's sea-level pressure: the recorded extremes (870 and
/// 1084 hPa) are 1190 m and 590 m from the standard 1013.25 hPa at 8.3 m per
/// hPa, so 1500 m bounds any real barometer. At this limit every navigator
/// that reads the barometer stays finite (tested); at 1e308 its noise made
/// the run diverge and its bias and drift put the height 6e306 m off.
pub const MAX_BARO_ERROR_M: f64 = 1500.0;

/// Shortest correlation time of a Gauss–Markov error (s:
/// `imu.gyro_bias_tau_s`, `imu.accel_bias_tau_s`, `baro.bias_tau_s`,
/// `filter.odometer_scale_tau_s`): the longest `filter.interval_s`, so that
/// the filter's first-order transition 1 − T/τ over a step T stays between 0
/// and 1 (at 1e-300 s it was −1e299: the covariance blew up and an
/// integrated run with baro aiding reported an error of exactly 0 m).
pub const MIN_CORRELATION_TIME_S: f64 = 10.0;

/// Longest correlation time of a Gauss–Markov error (s): 1e7 s (116 days),
/// four times the 30-day drive limit, so over any drive such an error is
/// already a constant (the filter models a random constant with 1e6 s).
pub const MAX_CORRELATION_TIME_S: f64 = 1e7;

/// Largest `[vehicle] lane_wander_m` (m, 1σ): drivers keep their lane to
/// 0.2–0.3 m (SDLP; the default 0.3), and at 2 m the vehicle's centre is
/// out of a 3.75 m lane a third of the time. At 1000 m a 4.1 km route was
/// driven as 75 km of zigzag, and at 1e308 the lane path had no length
/// (the error blamed the route).
pub const MAX_LANE_WANDER_M: f64 = 2.0;

/// Longest `output_interval_s` (s): a day, 30 rows over the longest drive;
/// at 1e308 the metrics were taken from the start and end rows alone.
pub const MAX_OUTPUT_INTERVAL_S: f64 = 86_400.0;

/// Horizontal error requirement (`requirement_m`, m): 1 mm to 100 km (the
/// limit of the navigator's initial position error). At 1e308 the plan's
/// summary printed a 309-digit requirement; at 1e-300 its error 300 zeros.
pub const REQUIREMENT_RANGE_M: (f64, f64) = (1e-3, 1e5);

/// Largest `[external_fix] random_walk_m_per_rts` (m/√s): 1 km after one
/// second, a source no filter can use (its fixes are then ignored); at
/// 1e308 the simulated fixes' random walk overflowed to infinity.
pub const MAX_FIX_RANDOM_WALK: f64 = 1000.0;

/// Shortest nonzero odometer pulse (`odometer.pulse_m`,
/// `diff_odometer.pulse_m`; m): 0.1 mm, 20,000 pulses per revolution of a
/// car's 2 m tyre, finer than wheel encoders resolve.
pub const MIN_PULSE_M: f64 = 1e-4;

/// Longest odometer pulse (m): one pulse per revolution of a 1.6 m tyre
/// (a car's tyre is about 2 m round, a truck's 3.3 m), the coarsest wheel
/// sensor. At 1e308 no pulse was ever counted and dead reckoning stood
/// still, silently.
pub const MAX_PULSE_M: f64 = 5.0;

/// Most candidate sites of a network plan (`coverage = "network"`): the
/// directed road pieces of the map, each cut every
/// `planner.candidate_spacing_m` (at least one site each). At the default
/// 50 m spacing that is about 25,000 km of directed road, 8 times the
/// Gothenburg map (60,000 candidates: 0.2 GB and 6 s for the any-walk plan;
/// the trips model's instance 0.25 GB, growing with the candidates, beside
/// its chains). Measured at the limit: see BENCHMARKS.md, "Network plan
/// candidate limit".
pub const MAX_NETWORK_CANDIDATE_SITES: u64 = 500_000;

/// Checks a network plan's candidate sites on the loaded map `net` against
/// [`MAX_NETWORK_CANDIDATE_SITES`] before the planner enumerates them: for
/// every section of positive length and every direction it may be driven
/// in, `ceil(length / candidate_spacing_m)` sites, at least one (an upper
/// bound: sections where no mounting is allowed get none). Returns that
/// count.
pub fn check_network_candidates(scn: &Scenario, net: &RoadNetwork) -> Result<u64> {
    let spacing = scn.planner().candidate_spacing_m;
    let (mut sites, mut pieces, mut length_m) = (0.0f64, 0u64, 0.0f64);
    for s in &net.sections {
        if s.length_m.is_nan() || s.length_m <= 0.0 {
            continue;
        }
        let directions =
            u64::from(s.oneway.allows_forward()) + u64::from(s.oneway.allows_backward());
        pieces += directions;
        length_m += directions as f64 * s.length_m;
        sites += directions as f64 * (s.length_m / spacing).ceil().max(1.0);
    }
    if sites.is_nan() || sites > MAX_NETWORK_CANDIDATE_SITES as f64 {
        return Err(Error::scenario(
            &scn.path,
            format!(
                "the map's {pieces} directed road pieces ({:.1} km) at planner.candidate_spacing_m \
                 = {spacing} give {sites:.0} candidate sites, above the limit of \
                 {MAX_NETWORK_CANDIDATE_SITES} for coverage = \"network\": use a larger \
                 candidate_spacing_m or a smaller map",
                length_m / 1000.0
            ),
        ));
    }
    Ok(sites as u64)
}

/// Most memory the truth of a map route may need while it is built
/// ([`route_truth_bytes`]): 2 GiB, about 9,000 km of city streets (the
/// Helsinki routes of BENCHMARKS.md: 58 vertices a kilometre), thirty
/// times the 297 km paper drive. Fixed, not a share of the machine's
/// memory, so that a scenario is accepted or refused alike on every
/// machine; of the size of the other in-memory limits (the error rows
/// [`crate::sim::MAX_STORED_ROWS`], 1.8 GB; a route plan's truth samples,
/// 1.5 GB), so that a drive at all of them, with a map of the 1 GiB limit,
/// stays well within the 24 GiB of this project's machines. The 30-day
/// drive limit does not bound it: at 300 km/h 30 days are 216,000 km,
/// about 50 GB.
pub const MAX_ROUTE_TRUTH_BYTES: u64 = 2 << 30;

/// Allowance (bytes per metre of route) for the lateral profile of the
/// lane path (`sim::lanes`): its wander's knots, 8 bytes every 15 m, and
/// its lane changes, 2 km apart on average (a test checks it against
/// those constants).
pub const LANE_PROFILE_BYTES_PER_M: f64 = 1.0;

/// The lane path's length taken by [`route_truth_bytes`], as a multiple
/// of the route's: on the outside of a bend the lane is longer than the
/// centre line (2.7 m a right angle at a 1.75 m offset); on the Helsinki
/// routes of BENCHMARKS.md it is 0.5 % shorter.
pub const LANE_PATH_LENGTH_FACTOR: f64 = 1.05;

/// The sizes a map route's memory is estimated from
/// ([`route_truth_bytes`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RouteCounts {
    /// Length of the route through the waypoints (m).
    pub length_m: f64,
    /// Points of its polyline.
    pub vertices: u64,
    /// Its spans (pieces of road).
    pub spans: u64,
    /// Its waypoints.
    pub waypoints: u64,
    /// Its stops.
    pub stops: u64,
    /// Whether its heights come from an elevation model (`[map] elevation`).
    pub elevation: bool,
}

impl RouteCounts {
    /// The counts of a routed `route` of `scn`.
    pub fn of(scn: &Scenario, route: &Route) -> RouteCounts {
        let stops = match &scn.route {
            super::RouteKind::Map { stops, .. } => stops.len() as u64,
            super::RouteKind::Motion { .. } => 0,
        };
        RouteCounts {
            length_m: route.length_m,
            vertices: route.vertices.len() as u64,
            spans: route.spans.len() as u64,
            waypoints: route.waypoints.len() as u64,
            stops,
            elevation: !scn.elevation.is_empty(),
        }
    }
}

/// An upper bound of the memory (bytes) of building the truth of a map
/// route (`sim::TruthSource`), whatever the IMU rate, the speed and
/// `duration_s` (the truth's samples are made as they are read; the route
/// is built whole). Its peak is while the lane path's plan is built:
/// - the route (its vertices, spans and waypoints);
/// - the plan of its smoothed centre path, as kept
///   ([`RoutePlan::memory_bytes`]), with its height profiles on a terrain;
/// - the lane path: its lateral profile, its polyline every
///   [`LANE_PATH_SPACING_M`] along the centre path (at most the route's
///   length) with the route's spans and waypoints, and its plan being built
///   on a path `LANE_PATH_LENGTH_FACTOR` times the route's length, with
///   at most one turn on the spot per route vertex.
///
/// At least 208 bytes a metre (232 on the Helsinki routes of BENCHMARKS.md,
/// with 58 route vertices a kilometre; 5–7 % above the bytes those builds
/// allocate, `tests/route_memory.rs`). The elevation model's raster is
/// not counted: it has its own limit ([`crate::elevation::MAX_DEM_PIXELS`]).
pub fn route_truth_bytes(c: &RouteCounts) -> u64 {
    use std::mem::size_of;
    let size = |n: u64, bytes: usize| n.saturating_mul(bytes as u64);
    let sum = |terms: &[u64]| terms.iter().fold(0u64, |a, &b| a.saturating_add(b));
    let per_m = |bytes_per_m: f64| (c.length_m * bytes_per_m).ceil() as u64;
    let route = |vertices: u64| {
        sum(&[
            size(vertices, size_of::<RouteVertex>()),
            size(c.spans, size_of::<RouteSpan>()),
            size(c.waypoints, size_of::<SnappedWaypoint>()),
        ])
    };
    let centre = RoutePlan::memory_bytes(c.vertices, c.vertices, c.spans, c.stops, c.length_m);
    let heights = if c.elevation {
        // The route's profile and the centre plan's, heights and grades.
        size(sum(&[per_m(1.0 / PROFILE_STEP_M), 2]), 4 * size_of::<f64>())
    } else {
        0
    };
    let lane_vertices = sum(&[(c.length_m / LANE_PATH_SPACING_M).ceil() as u64, 2]);
    // The lateral profile: a step (three f64) and its running sum at each
    // change of road (at most one per span; the steps in a vector grown by
    // doubling), and the allowance per metre.
    let profile = sum(&[
        size(c.spans, 2 * size_of::<[f64; 3]>() + size_of::<f64>()),
        per_m(LANE_PROFILE_BYTES_PER_M),
    ]);
    let lane = RoutePlan::memory_bytes(
        lane_vertices,
        c.vertices,
        c.spans,
        c.stops,
        LANE_PATH_LENGTH_FACTOR * c.length_m,
    );
    let building_centre = sum(&[route(c.vertices), centre.peak]);
    let building_lane = sum(&[
        route(c.vertices),
        centre.kept,
        heights,
        profile,
        route(lane_vertices),
        lane.peak,
    ]);
    building_centre.max(building_lane)
}

/// Checks the memory of building the truth of `scn`'s routed `route`
/// ([`route_truth_bytes`]) against [`MAX_ROUTE_TRUTH_BYTES`], before its
/// plan is made. Returns the estimate.
pub fn check_route_memory(scn: &Scenario, route: &Route) -> Result<u64> {
    let c = RouteCounts::of(scn, route);
    let bytes = route_truth_bytes(&c);
    if bytes > MAX_ROUTE_TRUTH_BYTES {
        return Err(Error::scenario(
            &scn.path,
            format!(
                "route[0]: the route through its {} waypoints is {:.0} km long ({} vertices): \
                 building its truth needs about {} of memory, {}",
                c.waypoints,
                c.length_m / 1000.0,
                c.vertices,
                gigabytes(bytes),
                over_route_memory_limit()
            ),
        ));
    }
    Ok(bytes)
}

/// `bytes` in GB, one decimal.
pub(super) fn gigabytes(bytes: u64) -> String {
    format!("{:.1} GB", bytes as f64 / 1e9)
}

/// The end of an error refusing a route for its memory: the limit, why
/// the memory grows with the route and what to change.
pub(super) fn over_route_memory_limit() -> String {
    let per_1000_km = route_truth_bytes(&RouteCounts {
        length_m: 1e6,
        vertices: 0,
        spans: 0,
        waypoints: 0,
        stops: 0,
        elevation: false,
    });
    format!(
        "above the limit of {} GiB ({}; the route's truth is built whole, with a point every \
         metre or two: at least {:.2} GB per 1000 km, whatever imu.rate_hz, speed_kmh and \
         duration_s): use fewer or closer waypoints",
        MAX_ROUTE_TRUTH_BYTES >> 30,
        gigabytes(MAX_ROUTE_TRUTH_BYTES),
        per_1000_km as f64 / 1e9,
    )
}

/// Checks the counts of `file` against the limits above, and that a motion
/// route has motion commands.
pub(super) fn check(c: &Check, file: &ScenarioFile) -> Result<()> {
    let imu = &file.imu;
    let mut terms: Vec<(String, f64, f64)> = Vec::new();
    for (name, v, max) in [
        ("gyro_bias_dph", imu.gyro_bias_dph, MAX_GYRO_ERROR_DPH),
        ("accel_bias_ug", imu.accel_bias_ug, MAX_ACCEL_ERROR_UG),
    ] {
        for (i, x) in v.iter().enumerate() {
            terms.push((format!("imu.{name}[{i}]"), *x, max));
        }
    }
    for (name, x, max) in [
        (
            "gyro_bias_instability_dph",
            imu.gyro_bias_instability_dph,
            MAX_GYRO_ERROR_DPH,
        ),
        (
            "gyro_bias_random_dph",
            imu.gyro_bias_random_dph,
            MAX_GYRO_ERROR_DPH,
        ),
        (
            "accel_bias_instability_ug",
            imu.accel_bias_instability_ug,
            MAX_ACCEL_ERROR_UG,
        ),
        (
            "accel_bias_random_ug",
            imu.accel_bias_random_ug,
            MAX_ACCEL_ERROR_UG,
        ),
        ("accel_vrw_ugprhz", imu.accel_vrw_ugprhz, MAX_ACCEL_ERROR_UG),
        ("gyro_arw_dprh", imu.gyro_arw_dprh, MAX_GYRO_ARW_DPRH),
    ] {
        terms.push((format!("imu.{name}"), x, max));
    }
    for (field, x, max) in terms {
        // NaN and infinity are left to the finite-number checks.
        if x.is_finite() && x.abs() > max {
            return Err(c.err(format!(
                "{field} = {} is beyond the limit of ±{max} (no sensor errs this much; \
                 the navigation would diverge)",
                short_number(x)
            )));
        }
    }
    if let Some(r) = file.route.first() {
        if r.start.is_some() && r.waypoints.is_none() && r.motion.is_empty() {
            return Err(c.err(
                "route[0].motion is empty: give at least one motion command (e.g. \
                 { kind = \"stay\", duration_s = 60 }); a drive of 0 s has nothing to simulate",
            ));
        }
    }
    let Some(p) = &file.planner else {
        return Ok(());
    };
    for (field, value, max) in [
        ("planner.validation_runs", p.validation_runs, MAX_RUNS),
        (
            "planner.tolerate_missed_reads",
            p.tolerate_missed_reads.map(u64::from),
            MAX_TOLERATED_MISSED_READS,
        ),
        (
            "planner.refine_iterations",
            p.refine_iterations.map(u64::from),
            MAX_REFINE_ITERATIONS,
        ),
    ] {
        if let Some(v) = value.filter(|&v| v > max) {
            return Err(c.err(format!("{field} = {v} is above the limit of {max}")));
        }
    }
    Ok(())
}

/// A pulse length (`field`, m): 0 (no quantization) or between
/// [`MIN_PULSE_M`] and [`MAX_PULSE_M`].
pub(super) fn pulse(c: &Check, field: &str, x: f64) -> Result<f64> {
    if x == 0.0 || (MIN_PULSE_M..=MAX_PULSE_M).contains(&x) {
        Ok(x)
    } else {
        Err(c.err(format!(
            "{field} must be 0 (no quantization) or between {MIN_PULSE_M} and {MAX_PULSE_M} m \
             (the distance per wheel pulse), got {}",
            short_number(x)
        )))
    }
}

/// `[map] geometry_error_m` and `geometry_error_correlation_m` (σ, L):
/// each within its limit, and σ at most [`MAX_MAP_ERROR_GRADIENT`] × L.
pub(super) fn map_error(c: &Check, sigma: f64, corr: f64) -> Result<(f64, f64)> {
    let sigma = c.range("map.geometry_error_m", sigma, 0.0, MAX_MAP_GEOMETRY_ERROR_M)?;
    let corr = c.positive("map.geometry_error_correlation_m", corr)?;
    if corr > MAX_MAP_ERROR_CORRELATION_M {
        return Err(c.err(format!(
            "map.geometry_error_correlation_m = {} is above the limit of \
             {MAX_MAP_ERROR_CORRELATION_M} m (longer than any map: a rigid shift already)",
            short_number(corr)
        )));
    }
    if sigma > MAX_MAP_ERROR_GRADIENT * corr {
        return Err(c.err(format!(
            "map.geometry_error_m = {} is more than a quarter of \
             map.geometry_error_correlation_m = {}: an error changing that fast folds \
             roads over each other; use a correlation length of at least {} m",
            short_number(sigma),
            short_number(corr),
            short_number(sigma / MAX_MAP_ERROR_GRADIENT)
        )));
    }
    Ok((sigma, corr))
}

/// A Gauss–Markov correlation time (`field`, s): between
/// [`MIN_CORRELATION_TIME_S`] and [`MAX_CORRELATION_TIME_S`].
pub(super) fn correlation_time(c: &Check, field: &str, x: f64) -> Result<f64> {
    c.range(field, x, MIN_CORRELATION_TIME_S, MAX_CORRELATION_TIME_S)
}
