//! Validation of the first `[[route]]`: waypoints on a map or a start with
//! motion commands, checked and converted to SI; and `[map] elevation`, the
//! terrain the map route is driven on.

use super::check::{short_number, shorten_numbers, Check};
use super::limits::{
    gigabytes, over_route_memory_limit, route_truth_bytes, RouteCounts, MAX_ELEVATION_FILES,
    MAX_HEADING_DEG, MAX_ROUTE_TRUTH_BYTES,
};
use super::schema::{Coverage, MotionKind, MotionSpec, OneOrMany, ScenarioFile};
use super::sections::RouteKind;
use crate::error::{Error, Result};
use crate::trajectory::motion::{MAX_DURATION_S, MAX_LONGITUDINAL_ACCEL};
use crate::trajectory::{Extent, Motion, Start};
use std::path::{Path, PathBuf};

/// The first route of `file`, validated.
pub(super) fn route(
    c: &Check,
    path: &Path,
    file: &ScenarioFile,
    coverage: Coverage,
) -> Result<RouteKind> {
    let Some(r) = file.route.first() else {
        // A network plan needs the map alone: a route without waypoints,
        // at the vehicles' speed.
        if let (Coverage::Network, Some(map)) = (coverage, &file.map) {
            let base = path.parent().unwrap_or(Path::new("."));
            return Ok(RouteKind::Map {
                map: base.join(&map.path),
                waypoints: Vec::new(),
                profile: crate::trajectory::route::SpeedProfile {
                    speed_mps: file.vehicle.speed_kmh.unwrap_or(50.0) / 3.6,
                    ..Default::default()
                },
                stops: Vec::new(),
                height_m: 0.0,
            });
        }
        return Err(c.err(
            "no [[route]]: give waypoints (with [map]) or start and motion (a network plan, \
             planner.coverage = \"network\", needs only [map])",
        ));
    };
    match (&r.waypoints, &r.start) {
        (Some(_), Some(_)) => Err(c.err(
            "route[0] has both waypoints and start; use waypoints on a map or start with motion commands",
        )),
        (None, None) => Err(c.err("route[0] needs waypoints (with [map]) or start and motion")),
        (None, Some(st)) => {
            if r.speed_kmh.is_some() || !r.stops.is_empty() {
                return Err(c.err(
                    "route[0]: speed_kmh and stops belong to waypoint routes; motion routes set speed with accelerate",
                ));
            }
            c.range("route[0].start.lat", st.lat, -89.0, 89.0)?;
            c.range("route[0].start.lon", st.lon, -180.0, 180.0)?;
            c.range("route[0].start.height_m", st.height_m, -1000.0, 10_000.0)?;
            let h = MAX_HEADING_DEG;
            c.range("route[0].start.heading_deg", st.heading_deg, -h, h)?;
            c.range("route[0].start.pitch_deg", st.pitch_deg, -45.0, 45.0)?;
            c.range("route[0].start.roll_deg", st.roll_deg, -60.0, 60.0)?;
            c.range("route[0].start.speed_kmh", st.speed_kmh, 0.0, 400.0)?;
            let start = Start {
                lat: st.lat.to_radians(),
                lon: st.lon.to_radians(),
                h: st.height_m,
                heading: st.heading_deg.to_radians(),
                pitch: st.pitch_deg.to_radians(),
                roll: st.roll_deg.to_radians(),
                speed_mps: st.speed_kmh / 3.6,
            };
            let mut commands = Vec::with_capacity(r.motion.len());
            for (i, m) in r.motion.iter().enumerate() {
                commands.push(motion(c, i, m)?);
            }
            // Compile once here so impossible motions are reported at load.
            crate::trajectory::MotionPlan::new(start, &commands, 1.0 / file.imu.rate_hz)
                .map_err(|e| c.err(strip_invalid(e)))?;
            Ok(RouteKind::Motion { start, commands })
        }
        (Some(w), None) => {
            if !r.motion.is_empty() {
                return Err(c.err("route[0]: motion commands need a start, not waypoints"));
            }
            let Some(map) = &file.map else {
                return Err(c.err("route[0] has waypoints but there is no [map] path"));
            };
            if w.len() < 2 {
                return Err(c.err("route[0].waypoints needs at least two points"));
            }
            for (i, p) in w.iter().enumerate() {
                c.range(&format!("route[0].waypoints[{i}] latitude"), p[0], -89.0, 89.0)?;
                c.range(&format!("route[0].waypoints[{i}] longitude"), p[1], -180.0, 180.0)?;
            }
            let speed = c.range("route[0].speed_kmh", r.speed_kmh.unwrap_or(40.0), 1.0, 300.0)?;
            check_waypoint_distances(c, w, speed)?;
            let mut profile = crate::trajectory::route::SpeedProfile {
                speed_mps: speed / 3.6,
                ..Default::default()
            };
            if let Some(x) = r.max_lateral_accel_mps2 {
                profile.max_lateral_accel_mps2 =
                    c.range("route[0].max_lateral_accel_mps2", x, 0.1, 8.0)?;
            }
            if let Some(x) = r.accel_mps2 {
                profile.accel_mps2 = c.range("route[0].accel_mps2", x, 0.05, 9.81)?;
            }
            if let Some(x) = r.brake_mps2 {
                profile.brake_mps2 = c.range("route[0].brake_mps2", x, 0.05, 9.81)?;
            }
            let mut stops = Vec::new();
            for (i, s) in r.stops.iter().enumerate() {
                let field = format!("route[0].stops[{i}].duration_s");
                // At 1e308 the drive's length saturated and its error
                // printed a wrong 18-digit duration.
                if c.positive(&field, s.duration_s)? > MAX_DURATION_S {
                    return Err(c.err(format!(
                        "{field} = {} is above the limit of {MAX_DURATION_S} s (30 days, the \
                         longest drive)",
                        short_number(s.duration_s)
                    )));
                }
                stops.push((
                    c.non_negative(&format!("route[0].stops[{i}].at_m"), s.at_m)?,
                    s.duration_s,
                ));
            }
            let height_m = c.range("route[0].height_m", r.height_m.unwrap_or(0.0), -1000.0, 10_000.0)?;
            let base = path.parent().unwrap_or(Path::new("."));
            Ok(RouteKind::Map {
                map: base.join(&map.path),
                waypoints: w.clone(),
                profile,
                stops,
                height_m,
            })
        }
    }
}

/// Smallest radius of curvature of the WGS-84 ellipsoid (m, b²/a, the
/// meridian's at the equator): great-circle distances on a sphere of this
/// radius are at most the distances on the ellipsoid.
const MIN_EARTH_RADIUS_M: f64 = 6_335_439.0;

/// Great-circle distance (m) between two [latitude, longitude] points in
/// degrees, on a sphere of [`MIN_EARTH_RADIUS_M`].
fn great_circle_m(a: [f64; 2], b: [f64; 2]) -> f64 {
    let (la, lb) = (a[0].to_radians(), b[0].to_radians());
    let dlat = lb - la;
    let dlon = (b[1] - a[1]).to_radians();
    let h = (0.5 * dlat).sin().powi(2) + la.cos() * lb.cos() * (0.5 * dlon).sin().powi(2);
    2.0 * MIN_EARTH_RADIUS_M * h.sqrt().min(1.0).asin()
}

/// A lower bound of the length (m) of a route through `waypoints`: each
/// leg at least the great-circle distance between its waypoints less the
/// distance each may be snapped to a road
/// ([`crate::route::DEFAULT_SNAP_TOLERANCE_M`]).
fn waypoints_length_lower_bound_m(waypoints: &[[f64; 2]]) -> f64 {
    let snap = 2.0 * crate::route::DEFAULT_SNAP_TOLERANCE_M;
    waypoints
        .windows(2)
        .map(|w| (great_circle_m(w[0], w[1]) - snap).max(0.0))
        .sum()
}

/// Refuses waypoints whose route could not be driven within the drive
/// limit ([`MAX_DURATION_S`], 30 days) at `speed_kmh`, or whose truth
/// would need more memory than [`MAX_ROUTE_TRUTH_BYTES`], from the
/// waypoints alone: before the map is loaded and the route is built (a
/// route of thousands of waypoints far apart was routed and sampled every
/// 2 m, gigabytes, before the drive's duration was checked). `duration_s`
/// does not lift them: the route is built whole even when the drive stops
/// earlier.
fn check_waypoint_distances(c: &Check, waypoints: &[[f64; 2]], speed_kmh: f64) -> Result<()> {
    let length_m = waypoints_length_lower_bound_m(waypoints);
    let drive_s = length_m / (speed_kmh / 3.6);
    if drive_s > MAX_DURATION_S {
        return Err(c.err(format!(
            "route[0]: its {} waypoints are {:.0} km apart at least (great-circle distances \
             between consecutive waypoints), a drive of at least {:.1} days at speed_kmh = {}, \
             above the limit of 30 days ({MAX_DURATION_S:.0} s; duration_s does not shorten the \
             route, which is built whole): use fewer or closer waypoints",
            waypoints.len(),
            length_m / 1000.0,
            drive_s / 86_400.0,
            short_number(speed_kmh)
        )));
    }
    // The same lower bound of the length against the memory of building
    // its truth (the route's vertices at least its waypoints).
    let n = waypoints.len() as u64;
    let bytes = route_truth_bytes(&RouteCounts {
        length_m,
        vertices: n,
        spans: n.saturating_sub(1),
        waypoints: n,
        stops: 0,
        elevation: false,
    });
    if bytes > MAX_ROUTE_TRUTH_BYTES {
        return Err(c.err(format!(
            "route[0]: its {} waypoints are {:.0} km apart at least (great-circle distances \
             between consecutive waypoints): building the truth of a route that long needs at \
             least {} of memory, {}",
            waypoints.len(),
            length_m / 1000.0,
            gigabytes(bytes),
            over_route_memory_limit()
        )));
    }
    Ok(())
}

/// `[map] elevation`: the DEM files resolved against the scenario's folder
/// (the files are read where the map is: in the truth and the planner).
pub(super) fn elevation(c: &Check, path: &Path, file: &ScenarioFile) -> Result<Vec<PathBuf>> {
    let Some(e) = file.map.as_ref().and_then(|m| m.elevation.as_ref()) else {
        return Ok(Vec::new());
    };
    let files = match e {
        OneOrMany::One(f) => vec![f.clone()],
        OneOrMany::Many(v) => v.clone(),
    };
    if files.is_empty() {
        return Err(c.err("map.elevation is an empty list: give one GeoTIFF or a list of tiles"));
    }
    if files.len() > MAX_ELEVATION_FILES {
        return Err(c.err(format!(
            "map.elevation lists {} files, above the limit of {MAX_ELEVATION_FILES}",
            files.len()
        )));
    }
    if file.route.first().is_some_and(|r| r.height_m.is_some()) {
        return Err(c.err(
            "route[0].height_m is the constant height of a map without an elevation model; \
             with map.elevation the heights come from the terrain (remove one of them)",
        ));
    }
    let base = path.parent().unwrap_or(Path::new("."));
    Ok(files.iter().map(|f| base.join(f)).collect())
}

/// The motion compiler's error as a scenario error's message: its field
/// named as in the file, numbers of more than 24 digits short (`1e308 m/s²`,
/// not 309 digits).
fn strip_invalid(e: Error) -> String {
    shorten_numbers(&match e {
        Error::InvalidParameter(m) => m.replacen("route.", "route[0].", 1),
        other => other.to_string(),
    })
}

fn motion(c: &Check, i: usize, m: &MotionSpec) -> Result<Motion> {
    let f = |name: &str| format!("route[0].motion[{i}].{name}");
    let need = |name: &str, x: Option<f64>| -> Result<f64> {
        x.ok_or_else(|| {
            c.err(format!(
                "route[0].motion[{i}] ({}) needs {name}",
                m.kind.as_str()
            ))
        })
    };
    let extent = || -> Result<Extent> {
        match (m.duration_s, m.distance_m) {
            (Some(t), None) => Ok(Extent::Duration(c.positive(&f("duration_s"), t)?)),
            (None, Some(d)) => Ok(Extent::Distance(c.positive(&f("distance_m"), d)?)),
            _ => Err(c.err(format!(
                "route[0].motion[{i}] ({}) needs exactly one of duration_s and distance_m",
                m.kind.as_str()
            ))),
        }
    };
    let forbid = |names: &[(&str, bool)]| -> Result<()> {
        for (n, present) in names {
            if *present {
                return Err(c.err(format!(
                    "route[0].motion[{i}] ({}) does not take {n}",
                    m.kind.as_str()
                )));
            }
        }
        Ok(())
    };
    let speed_fields = [
        ("to_kmh", m.to_kmh.is_some()),
        ("accel_mps2", m.accel_mps2.is_some()),
    ];
    let turn_fields = [
        ("angle_deg", m.angle_deg.is_some()),
        ("radius_m", m.radius_m.is_some()),
    ];
    let grade_fields = [
        ("grade_percent", m.grade_percent.is_some()),
        ("pitch_rate_dps", m.pitch_rate_dps.is_some()),
    ];
    let time_fields = [
        ("duration_s", m.duration_s.is_some()),
        ("distance_m", m.distance_m.is_some()),
    ];
    let kind = m.kind;
    Ok(match kind {
        MotionKind::Stay => {
            forbid(&speed_fields)?;
            forbid(&turn_fields)?;
            forbid(&grade_fields)?;
            forbid(&[("distance_m", m.distance_m.is_some())])?;
            Motion::Stay {
                duration_s: c.positive(&f("duration_s"), need("duration_s", m.duration_s)?)?,
            }
        }
        MotionKind::Accelerate | MotionKind::Decelerate => {
            forbid(&turn_fields)?;
            forbid(&grade_fields)?;
            forbid(&time_fields)?;
            Motion::ChangeSpeed {
                to_mps: c.range(&f("to_kmh"), need("to_kmh", m.to_kmh)?, 0.0, 400.0)? / 3.6,
                // As a map route's accel_mps2 and brake_mps2.
                accel_mps2: c.range(
                    &f("accel_mps2"),
                    m.accel_mps2.unwrap_or(1.0),
                    0.05,
                    MAX_LONGITUDINAL_ACCEL,
                )?,
                decelerate: kind == MotionKind::Decelerate,
            }
        }
        MotionKind::Cruise => {
            forbid(&speed_fields)?;
            forbid(&turn_fields)?;
            forbid(&grade_fields)?;
            Motion::Cruise { extent: extent()? }
        }
        MotionKind::Turn => {
            forbid(&speed_fields)?;
            forbid(&grade_fields)?;
            forbid(&time_fields)?;
            let a = c.range(
                &f("angle_deg"),
                need("angle_deg", m.angle_deg)?,
                -3600.0,
                3600.0,
            )?;
            if a == 0.0 {
                return Err(c.err(format!("{} must not be zero", f("angle_deg"))));
            }
            Motion::Turn {
                angle: a.to_radians(),
                radius_m: c.positive(&f("radius_m"), need("radius_m", m.radius_m)?)?,
            }
        }
        MotionKind::Climb | MotionKind::Descend => {
            forbid(&speed_fields)?;
            forbid(&turn_fields)?;
            let g = c.range(
                &f("grade_percent"),
                need("grade_percent", m.grade_percent)?,
                0.0,
                100.0,
            )?;
            let sign = if kind == MotionKind::Climb { 1.0 } else { -1.0 };
            Motion::Climb {
                grade: sign * g / 100.0,
                extent: extent()?,
                // At most 90 °/s: through a 45° ramp in half a second, a
                // crash rather than a drive; faster rates ended within one
                // IMU step (4,500 °/s at 100 Hz), a silent one-sample ramp.
                pitch_rate: {
                    let field = f("pitch_rate_dps");
                    let x = c.positive(&field, m.pitch_rate_dps.unwrap_or(1.0))?;
                    c.range(&field, x, 0.0, 90.0)?.to_radians()
                },
            }
        }
    })
}
