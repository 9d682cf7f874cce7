//! The one validation pass: raw [`ScenarioFile`] → [`Scenario`]. Every number
//! is checked (finite, in range), every default applied and every unit
//! converted to SI here, once; every error names the file and the field.

use super::check::{short_number, shorten_numbers, Check};
use super::limits::{
    correlation_time, MAX_BARO_ERROR_M, MAX_FIX_RANDOM_WALK, MAX_LANE_WANDER_M,
    MAX_OUTPUT_INTERVAL_S, MAX_SURVEY_ERROR_M, REQUIREMENT_RANGE_M,
};
use super::planner_section::planner;
use super::route::{elevation, route};
use super::schema::*;
use super::sections::*;
use crate::error::{Error, Result};
use crate::sensors::{
    BarometerModel, DiffOdometerModel, ImuModel, OdometerFailure, OdometerModel,
    RotationModulation, WheelSlip,
};
use crate::tags::{Mounting, RfidModel};
use crate::units::{ARCMIN, ARCSEC, DPH, G0};
use std::path::Path;

/// Largest odometer speed noise (`odometer.noise_mps`,
/// `diff_odometer.noise_mps`; m/s, 1σ per sample): the limit the filter
/// takes for its own `filter.odometer_noise_mps`.
const MAX_ODOMETER_NOISE_MPS: f64 = 10.0;

/// One-line description of a TOML parse error with its line number and,
/// where the error is about a value, the field holding it (e.g.
/// `line 12: planner.coverage "everything" is not one of routes, network`).
fn toml_error(text: &str, e: &toml::de::Error) -> String {
    // serde's names of TOML's kinds of value: a table is a "map", an array
    // a "sequence".
    let msg = shorten_numbers(&e.message().replace('\n', " "))
        .replace("invalid type: map,", "invalid type: table,")
        .replace("invalid type: sequence,", "invalid type: array,");
    let msg = msg.trim();
    let Some(span) = e.span() else {
        return msg.to_string();
    };
    let line = text[..span.start.min(text.len())].matches('\n').count() + 1;
    let field = toml::de::DeTable::parse(text)
        .ok()
        .and_then(|t| field_at(t.get_ref(), &span, ""));
    match (field, unknown_variant(msg)) {
        (Some(f), Some(m)) => format!("line {line}: {f} {m}"),
        (None, Some(m)) => format!("line {line}: {m}"),
        (Some(f), None) => format!("line {line}: {f}: {msg}"),
        (None, None) => format!("line {line}: {msg}"),
    }
}

/// serde's "unknown variant `x`, expected `a` or `b`" (or "expected one of
/// `a`, `b`, `c`") as `"x" is not one of a, b`.
fn unknown_variant(msg: &str) -> Option<String> {
    let rest = msg.strip_prefix("unknown variant `")?;
    let (value, expected) = rest.split_once("`, expected ")?;
    let names = expected
        .trim_start_matches("one of ")
        .replace("` or `", "`, `")
        .replace('`', "");
    Some(format!("\"{value}\" is not one of {names}"))
}

/// The dotted name (`planner.mountings[1]`, `route[0].motion[2].kind`) of the
/// value whose span is `span`, or of the table holding the key whose span it
/// is, searched from `table` named `prefix`.
fn field_at(
    table: &toml::de::DeTable<'_>,
    span: &std::ops::Range<usize>,
    prefix: &str,
) -> Option<String> {
    for (k, v) in table {
        if k.span() == *span && !prefix.is_empty() {
            // An unknown key or map key: name the table holding it.
            return Some(prefix.to_string());
        }
        let name = if prefix.is_empty() {
            k.get_ref().to_string()
        } else {
            format!("{prefix}.{}", k.get_ref())
        };
        if let Some(f) = value_at(v, span, name) {
            return Some(f);
        }
    }
    None
}

fn value_at(
    v: &toml::Spanned<toml::de::DeValue<'_>>,
    span: &std::ops::Range<usize>,
    name: String,
) -> Option<String> {
    use toml::de::DeValue;
    match v.get_ref() {
        DeValue::Table(t) => {
            field_at(t, span, &name).or_else(|| (v.span() == *span).then_some(name))
        }
        DeValue::Array(a) => a
            .iter()
            .enumerate()
            .find_map(|(i, x)| value_at(x, span, format!("{name}[{i}]")))
            .or_else(|| (v.span() == *span).then_some(name)),
        _ => (v.span() == *span).then_some(name),
    }
}

impl Scenario {
    /// Reads and validates a scenario file.
    pub fn load(path: &Path) -> Result<Scenario> {
        let text = crate::fsio::read_text_limited(path, super::MAX_SCENARIO_BYTES, "scenario")?;
        tracing::debug!("reading scenario {}", path.display());
        Self::parse(path, &text)
    }

    /// Parses and validates scenario text; `path` names it in errors and
    /// anchors relative map paths.
    pub fn parse(path: &Path, text: &str) -> Result<Scenario> {
        let file: ScenarioFile =
            toml::from_str(text).map_err(|e| Error::scenario(path, toml_error(text, &e)))?;
        // An `[imu] grade` fills the fields the file leaves out (the text is
        // parsed a second time only then).
        let file = match file.imu.grade {
            Some(_) => match super::presets::apply_imu_grade(text) {
                Ok(Some(doc)) => {
                    use serde::Deserialize;
                    ScenarioFile::deserialize(doc)
                        .map_err(|e| Error::scenario(path, shorten_numbers(&e.to_string())))?
                }
                _ => file,
            },
            None => file,
        };
        let c = Check { path };
        if let Some(r) = file.requirement_m {
            let (lo, hi) = REQUIREMENT_RANGE_M;
            c.range("requirement_m", r, lo, hi)?;
        }
        let output_interval_s = match file.output_interval_s {
            Some(x) => c.range("output_interval_s", x, 0.0, MAX_OUTPUT_INTERVAL_S)?,
            None => 1.0,
        };
        if let Some(d) = file.duration_s {
            // A cap shorter than one output interval leaves a run of 0 s
            // (all its figures 0, exit 0).
            if c.positive("duration_s", d)? < output_interval_s {
                return Err(c.err(format!(
                    "duration_s = {} is shorter than output_interval_s = {}: the run \
                     would end before its first row after the start",
                    short_number(d),
                    short_number(output_interval_s)
                )));
            }
        }
        // IMU
        let s = &file.imu;
        let rate = c.range("imu.rate_hz", s.rate_hz, 1.0, 10_000.0)?;
        let dt = 1.0 / rate;
        if output_interval_s < dt {
            return Err(c.err("output_interval_s must be at least one IMU interval"));
        }
        c.finite_all("imu.gyro_bias_dph", &s.gyro_bias_dph)?;
        c.finite_all("imu.accel_bias_ug", &s.accel_bias_ug)?;
        c.non_negative("imu.gyro_bias_instability_dph", s.gyro_bias_instability_dph)?;
        correlation_time(&c, "imu.gyro_bias_tau_s", s.gyro_bias_tau_s)?;
        c.non_negative("imu.accel_bias_instability_ug", s.accel_bias_instability_ug)?;
        correlation_time(&c, "imu.accel_bias_tau_s", s.accel_bias_tau_s)?;
        c.non_negative("imu.gyro_arw_dprh", s.gyro_arw_dprh)?;
        c.non_negative("imu.accel_vrw_ugprhz", s.accel_vrw_ugprhz)?;
        for (f, v) in [
            ("imu.gyro_scale_factor_ppm", &s.gyro_scale_factor_ppm),
            ("imu.accel_scale_factor_ppm", &s.accel_scale_factor_ppm),
        ] {
            for (i, x) in v.iter().enumerate() {
                c.range(&format!("{f}[{i}]"), *x, -1e5, 1e5)?;
            }
        }
        for (f, v) in [
            ("imu.gyro_misalignment_arcsec", &s.gyro_misalignment_arcsec),
            (
                "imu.accel_misalignment_arcsec",
                &s.accel_misalignment_arcsec,
            ),
        ] {
            for (i, x) in v.iter().enumerate() {
                c.range(&format!("{f}[{i}]"), *x, -36_000.0, 36_000.0)?;
            }
        }
        let rotation = match s.rotation_modulation {
            Some(r) => {
                let rate = c.range(
                    "imu.rotation_modulation.rate_dps",
                    r.rate_dps,
                    -360.0,
                    360.0,
                )?;
                if rate == 0.0 {
                    return Err(c.err("imu.rotation_modulation.rate_dps must not be zero"));
                }
                Some(RotationModulation {
                    rate: rate.to_radians(),
                })
            }
            None => None,
        };
        let imu = ImuModel {
            gyro_bias: s.gyro_bias_dph.map(|x| x * DPH),
            accel_bias: s.accel_bias_ug.map(|x| x * 1e-6 * G0),
            gyro_bias_instability: s.gyro_bias_instability_dph * DPH,
            gyro_bias_tau_s: s.gyro_bias_tau_s,
            accel_bias_instability: s.accel_bias_instability_ug * 1e-6 * G0,
            accel_bias_tau_s: s.accel_bias_tau_s,
            gyro_arw: s.gyro_arw_dprh.to_radians() / 60.0,
            accel_vrw: s.accel_vrw_ugprhz * 1e-6 * G0,
            gyro_scale_factor: s.gyro_scale_factor_ppm.map(|x| x * 1e-6),
            accel_scale_factor: s.accel_scale_factor_ppm.map(|x| x * 1e-6),
            gyro_misalignment: s.gyro_misalignment_arcsec.map(|x| x * ARCSEC),
            accel_misalignment: s.accel_misalignment_arcsec.map(|x| x * ARCSEC),
        };
        // Odometer
        let o = &file.odometer;
        c.range(
            "odometer.scale_factor_error",
            o.scale_factor_error,
            -0.5,
            0.5,
        )?;
        // At most 10 m/s per sample, the filter's own limit for
        // `filter.odometer_noise_mps`: at 1e308 a dead-reckoning run stayed
        // finite row by row while its RMS overflowed (null in summary.json).
        c.range(
            "odometer.noise_mps",
            o.noise_mps,
            0.0,
            MAX_ODOMETER_NOISE_MPS,
        )?;
        super::limits::pulse(&c, "odometer.pulse_m", o.pulse_m)?;
        let slip = match o.slip {
            Some(sl) => Some(WheelSlip {
                rate_per_km: c.non_negative("odometer.slip.rate_per_km", sl.rate_per_km)?,
                length_m: c.non_negative("odometer.slip.length_m", sl.length_m)?,
                overcount: c.range("odometer.slip.overcount", sl.overcount, -1.0, 10.0)?,
            }),
            None => None,
        };
        let failure = match o.failure {
            Some(f) => {
                if f.from_s.is_none() && f.from_m.is_none() {
                    return Err(c.err("odometer.failure needs from_s or from_m"));
                }
                if let Some(x) = f.from_s {
                    c.non_negative("odometer.failure.from_s", x)?;
                }
                if let Some(x) = f.from_m {
                    c.non_negative("odometer.failure.from_m", x)?;
                }
                Some(OdometerFailure {
                    from_s: f.from_s,
                    from_m: f.from_m,
                })
            }
            None => None,
        };
        // The per-run scale factor: 10 % is a wheel of the wrong size, not
        // a calibration's uncertainty.
        c.range(
            "odometer.scale_factor_sigma",
            o.scale_factor_sigma,
            0.0,
            0.1,
        )?;
        // The filter's misalignment states are small angles (its prior's
        // own limit is 10°): a larger mounting error is a different vehicle
        // axis, not a misalignment.
        for (k, axis) in ["pitch", "yaw"].iter().enumerate() {
            c.range(
                &format!("odometer.misalignment_deg[{k}] ({axis})"),
                o.misalignment_deg[k],
                -10.0,
                10.0,
            )?;
        }
        c.range(
            "odometer.misalignment_sigma_deg",
            o.misalignment_sigma_deg,
            0.0,
            5.0,
        )?;
        // A time-varying scale factor: as large as the per-run one, and its
        // correlation time as every other's.
        c.range(
            "odometer.scale_factor_instability",
            o.scale_factor_instability,
            0.0,
            0.1,
        )?;
        correlation_time(&c, "odometer.scale_factor_tau_s", o.scale_factor_tau_s)?;
        let misaligned = o.misalignment_deg != [0.0; 2] || o.misalignment_sigma_deg != 0.0;
        if misaligned && rotation.is_some() {
            return Err(c.err(
                "odometer.misalignment_deg and misalignment_sigma_deg cannot be combined with \
                 imu.rotation_modulation (the misalignment is of the IMU's base, which the \
                 modulation turns under)",
            ));
        }
        let odometer = OdometerModel {
            scale_factor_error: o.scale_factor_error,
            noise_mps: o.noise_mps,
            pulse_m: o.pulse_m,
            slip,
            failure,
            scale_factor_sigma: o.scale_factor_sigma,
            misalignment: o.misalignment_deg.map(f64::to_radians),
            misalignment_sigma: o.misalignment_sigma_deg.to_radians(),
            scale_factor_instability: o.scale_factor_instability,
            scale_factor_tau_s: o.scale_factor_tau_s,
        };
        // Vehicle and differential odometer
        c.range("vehicle.width_m", file.vehicle.width_m, 0.5, 10.0)?;
        let track = c.range(
            "vehicle.track_width_m",
            file.vehicle.track_width_m,
            0.3,
            10.0,
        )?;
        let d = &file.diff_odometer;
        c.range(
            "diff_odometer.scale_factor_error_left",
            d.scale_factor_error_left,
            -0.5,
            0.5,
        )?;
        c.range(
            "diff_odometer.scale_factor_error_right",
            d.scale_factor_error_right,
            -0.5,
            0.5,
        )?;
        c.range(
            "diff_odometer.track_width_error_m",
            d.track_width_error_m,
            -0.5 * track,
            0.5 * track,
        )?;
        c.range(
            "diff_odometer.noise_mps",
            d.noise_mps,
            0.0,
            MAX_ODOMETER_NOISE_MPS,
        )?;
        super::limits::pulse(&c, "diff_odometer.pulse_m", d.pulse_m)?;
        let diff_odometer = DiffOdometerModel {
            track_width_m: track,
            track_width_error_m: d.track_width_error_m,
            scale_factor_error_left: d.scale_factor_error_left,
            scale_factor_error_right: d.scale_factor_error_right,
            noise_mps: d.noise_mps,
            pulse_m: d.pulse_m,
        };
        // Baro
        let b = &file.baro;
        let baro = BarometerModel {
            rate_hz: c.range("baro.rate_hz", b.rate_hz, 0.01, rate)?,
            noise_m: c.range("baro.noise_m", b.noise_m, 0.0, MAX_BARO_ERROR_M)?,
            initial_bias_m: c.range(
                "baro.initial_bias_m",
                b.initial_bias_m,
                -MAX_BARO_ERROR_M,
                MAX_BARO_ERROR_M,
            )?,
            bias_drift_m: c.range("baro.bias_drift_m", b.bias_drift_m, 0.0, MAX_BARO_ERROR_M)?,
            bias_tau_s: correlation_time(&c, "baro.bias_tau_s", b.bias_tau_s)?,
            scale_factor_error: c.range(
                "baro.scale_factor_error",
                b.scale_factor_error,
                -0.5,
                0.5,
            )?,
        };
        c.range(
            "level_sensor.noise_deg",
            file.level_sensor.noise_deg,
            0.0,
            10.0,
        )?;
        // Navigator
        let n = &file.navigator;
        if let Some(t) = n.vertical_tau_s {
            c.range("navigator.vertical_tau_s", t, 1.0, 1e5)?;
        }
        for (i, x) in n.initial_attitude_error_arcmin.iter().enumerate() {
            c.range(
                &format!("navigator.initial_attitude_error_arcmin[{i}]"),
                *x,
                -600.0,
                600.0,
            )?;
        }
        for (i, x) in n.initial_velocity_error_mps.iter().enumerate() {
            c.range(
                &format!("navigator.initial_velocity_error_mps[{i}]"),
                *x,
                -100.0,
                100.0,
            )?;
        }
        c.range(
            "navigator.initial_attitude_sigma_arcmin[0]",
            n.initial_attitude_sigma_arcmin[0],
            0.0,
            600.0,
        )?;
        c.range(
            "navigator.initial_attitude_sigma_arcmin[1]",
            n.initial_attitude_sigma_arcmin[1],
            0.0,
            600.0,
        )?;
        c.range(
            "navigator.initial_position_sigma_m[0]",
            n.initial_position_sigma_m[0],
            0.0,
            1e5,
        )?;
        c.range(
            "navigator.initial_position_sigma_m[1]",
            n.initial_position_sigma_m[1],
            0.0,
            1e5,
        )?;
        c.range(
            "navigator.initial_velocity_sigma_mps",
            n.initial_velocity_sigma_mps,
            0.0,
            100.0,
        )?;
        for (i, x) in n.initial_position_error_m.iter().enumerate() {
            c.range(
                &format!("navigator.initial_position_error_m[{i}]"),
                *x,
                -1e5,
                1e5,
            )?;
        }
        let mut rfid = RfidModel {
            vehicle_width_m: file.vehicle.width_m,
            ..Default::default()
        };
        if let Some(p) = &file.rfid {
            let opt = |name: &str, x: Option<f64>, lo: f64, hi: f64, dst: &mut f64| -> Result<()> {
                if let Some(x) = x {
                    *dst = c.range(&format!("rfid.{name}"), x, lo, hi)?;
                }
                Ok(())
            };
            opt(
                "read_probability",
                p.read_probability,
                0.0,
                1.0,
                &mut rfid.read_probability,
            )?;
            for (i, (name, x)) in [
                (
                    "read_probability_road_surface",
                    p.read_probability_road_surface,
                ),
                ("read_probability_roadside", p.read_probability_roadside),
                ("read_probability_ceiling", p.read_probability_ceiling),
            ]
            .into_iter()
            .enumerate()
            {
                if let Some(x) = x {
                    rfid.read_probability_by_mounting[i] =
                        Some(c.range(&format!("rfid.{name}"), x, 0.0, 1.0)?);
                }
            }
            opt(
                "lane_width_m",
                p.lane_width_m,
                1.0,
                10.0,
                &mut rfid.lane_width_m,
            )?;
            opt(
                "roadside_distance_m",
                p.roadside_distance_m,
                0.0,
                50.0,
                &mut rfid.roadside_distance_m,
            )?;
            let mut ang = rfid.roadside_angle.to_degrees();
            opt(
                "roadside_angle_deg",
                p.roadside_angle_deg,
                0.0,
                80.0,
                &mut ang,
            )?;
            rfid.roadside_angle = ang.to_radians();
            opt(
                "read_time_s",
                p.read_time_s,
                0.0,
                1.0,
                &mut rfid.read_time_s,
            )?;
            opt(
                "roadside_range_m",
                p.roadside_range_m,
                0.5,
                100.0,
                &mut rfid.roadside_range_m,
            )?;
            opt(
                "road_surface_sigma_m",
                p.road_surface_sigma_m,
                0.0,
                0.5,
                &mut rfid.road_surface_sigma_m,
            )?;
            opt(
                "ceiling_sigma_m",
                p.ceiling_sigma_m,
                0.0,
                0.3,
                &mut rfid.ceiling_sigma_m,
            )?;
            opt(
                "height_sigma_m",
                p.height_sigma_m,
                0.0,
                100.0,
                &mut rfid.height_sigma_m,
            )?;
        }
        c.non_negative("imu.gyro_bias_random_dph", file.imu.gyro_bias_random_dph)?;
        c.non_negative("imu.accel_bias_random_ug", file.imu.accel_bias_random_ug)?;
        let tags = scenario_tags(&c, &file.tag)?;
        let fs = &file.filter;
        for (name, x, lo, hi) in [
            ("filter.interval_s", fs.interval_s, dt, 10.0),
            (
                "filter.odometer_interval_s",
                fs.odometer_interval_s,
                dt,
                10.0,
            ),
            (
                "filter.odometer_noise_mps",
                fs.odometer_noise_mps,
                1e-4,
                10.0,
            ),
            ("filter.nhc_noise_mps", fs.nhc_noise_mps, 1e-4, 10.0),
            (
                "filter.gyro_bias_sigma_dph",
                fs.gyro_bias_sigma_dph,
                0.0,
                1e4,
            ),
            (
                "filter.accel_bias_sigma_ug",
                fs.accel_bias_sigma_ug,
                0.0,
                1e6,
            ),
            (
                "filter.odometer_scale_sigma",
                fs.odometer_scale_sigma,
                0.0,
                0.5,
            ),
            (
                "filter.odometer_misalignment_sigma_deg",
                fs.odometer_misalignment_sigma_deg,
                0.0,
                10.0,
            ),
            (
                "filter.velocity_sigma_mps",
                fs.velocity_sigma_mps,
                0.0,
                100.0,
            ),
        ] {
            if let Some(x) = x {
                c.range(name, x, lo, hi)?;
            }
        }
        if let Some(t) = fs.odometer_scale_tau_s {
            correlation_time(&c, "filter.odometer_scale_tau_s", t)?;
        }
        if let Some(a) = fs.attitude_sigma_arcmin {
            c.range("filter.attitude_sigma_arcmin[0]", a[0], 0.0, 600.0)?;
            c.range("filter.attitude_sigma_arcmin[1]", a[1], 0.0, 600.0)?;
        }
        if let Some(a) = fs.position_sigma_m {
            c.range("filter.position_sigma_m[0]", a[0], 0.0, 1e5)?;
            c.range("filter.position_sigma_m[1]", a[1], 0.0, 1e5)?;
        }
        let external_fix = match &file.external_fix {
            Some(x) => Some(external_fix(&c, x, dt)?),
            None if file.aiding.external_fix => {
                return Err(c.err("aiding.external_fix needs an [external_fix] section"))
            }
            None => None,
        };
        let planner = planner(
            &c,
            path,
            file.planner.clone().unwrap_or_default(),
            &file.vehicle,
        )?;
        let route = route(&c, path, &file, planner.coverage)?;
        super::limits::check(&c, &file)?;
        let map_error = map_error(&c, file.map.as_ref())?;
        let elevation = elevation(&c, path, &file)?;
        let filter = filter(&file, &odometer, dt);
        let a = file.aiding;
        let n = &file.navigator;
        Ok(Scenario {
            path: path.to_path_buf(),
            route,
            dt,
            imu,
            rotation,
            odometer,
            diff_odometer,
            baro,
            initial_attitude_error: n.initial_attitude_error_arcmin.map(|x| x * ARCMIN),
            output_interval_s,
            rfid,
            map_error,
            elevation,
            lanes: LaneModel {
                drive_side: file.vehicle.drive_side.unwrap_or_default(),
                wander_m: c.range(
                    "vehicle.lane_wander_m",
                    file.vehicle.lane_wander_m.unwrap_or(DEFAULT_LANE_WANDER_M),
                    0.0,
                    MAX_LANE_WANDER_M,
                )?,
            },
            name: file.name.clone(),
            requirement_m: file.requirement_m,
            duration_cap_s: file.duration_s.unwrap_or(f64::INFINITY),
            seed: file.seed.unwrap_or(1),
            navigator: Navigator {
                mode: n.mode,
                vertical_channel: n.vertical_channel,
                vertical_tau_s: n.vertical_tau_s.unwrap_or(DEFAULT_VERTICAL_TAU_S),
                initial_velocity_error_mps: n.initial_velocity_error_mps,
                initial_position_error_m: n.initial_position_error_m,
                initial_attitude_sigma: n.initial_attitude_sigma_arcmin.map(|x| x * ARCMIN),
                initial_position_sigma_m: n.initial_position_sigma_m,
                initial_velocity_sigma_mps: n.initial_velocity_sigma_mps,
            },
            aiding: Aiding {
                odometer: a.odometer,
                rfid: a.rfid,
                map_matching: a.map_matching,
                baro: a.baro,
                non_holonomic: a.non_holonomic.unwrap_or(a.odometer),
                external_fix: a.external_fix,
            },
            filter,
            external_fix,
            tags,
            planner,
            level_sensor_noise: file.level_sensor.noise_deg.to_radians(),
            gyro_bias_random: file.imu.gyro_bias_random_dph * DPH,
            accel_bias_random: file.imu.accel_bias_random_ug * 1e-6 * G0,
        })
    }
}

/// `[map] geometry_error_m` and `geometry_error_correlation_m`, checked, with
/// their defaults.
fn map_error(c: &Check, m: Option<&MapSection>) -> Result<MapErrorModel> {
    let d = MapErrorModel::default();
    let sigma = m.and_then(|m| m.geometry_error_m).unwrap_or(d.sigma_m);
    let corr = m
        .and_then(|m| m.geometry_error_correlation_m)
        .unwrap_or(d.correlation_m);
    let (sigma_m, correlation_m) = super::limits::map_error(c, sigma, corr)?;
    Ok(MapErrorModel {
        sigma_m,
        correlation_m,
    })
}

/// The `[[tag]]` entries, checked, with their defaults.
fn scenario_tags(c: &Check, specs: &[TagSpec]) -> Result<Vec<ScenarioTag>> {
    let mut tags = Vec::with_capacity(specs.len());
    for (i, t) in specs.iter().enumerate() {
        let f = |n: &str| format!("tag[{i}].{n}");
        let place = match (t.lat, t.lon, t.at_s, t.at_m) {
            (Some(lat), Some(lon), None, None) => TagPlace::LatLonDeg([
                c.range(&f("lat"), lat, -89.0, 89.0)?,
                c.range(&f("lon"), lon, -180.0, 180.0)?,
            ]),
            (None, None, Some(x), None) => TagPlace::AtTime(c.non_negative(&f("at_s"), x)?),
            (None, None, None, Some(x)) => TagPlace::AtDistance(c.non_negative(&f("at_m"), x)?),
            _ => {
                return Err(c.err(format!(
                    "tag[{i}] needs exactly one of lat+lon, at_s and at_m"
                )))
            }
        };
        if let Some(x) = t.height_m {
            c.range(&f("height_m"), x, -1000.0, 10_000.0)?;
        }
        let survey_error_m = t.survey_error_m.unwrap_or([0.0, 0.0]);
        for (k, x) in survey_error_m.iter().enumerate() {
            let s = MAX_SURVEY_ERROR_M;
            c.range(&f(&format!("survey_error_m[{k}]")), *x, -s, s)?;
        }
        tags.push(ScenarioTag {
            id: t.id.clone().unwrap_or_else(|| format!("tag-{i}")),
            place,
            height_m: t.height_m,
            mounting: t.mounting.unwrap_or(Mounting::RoadSurface),
            survey_error_m,
        });
    }
    unique_ids(c, specs, &tags)?;
    Ok(tags)
}

/// No two `[[tag]]` entries share an id (as in a tag CSV file): an entry
/// without one is `tag-N`, which an explicit id may not take either.
fn unique_ids(c: &Check, specs: &[TagSpec], tags: &[ScenarioTag]) -> Result<()> {
    let mut seen = std::collections::HashMap::with_capacity(tags.len());
    for (i, t) in tags.iter().enumerate() {
        if let Some(j) = seen.insert(t.id.as_str(), i) {
            let entry = match specs[i].id {
                Some(_) => format!("tag[{i}].id \"{}\"", t.id),
                None => format!("tag[{i}] (without id, so \"{}\")", t.id),
            };
            return Err(c.err(format!(
                "{entry} repeats the id of tag[{j}]: each tag needs its own id \
                 (an entry without id is tag-N)"
            )));
        }
    }
    Ok(())
}

/// `[external_fix]`, checked, with its defaults.
fn external_fix(c: &Check, x: &ExternalFixSection, dt: f64) -> Result<ExternalFix> {
    let [a, b] = x.interval_s;
    c.range("external_fix.interval_s[0]", a, dt, 1e5)?;
    c.range("external_fix.interval_s[1]", b, a, 1e5)?;
    c.range("external_fix.white_m", x.white_m, 0.0, 1e5)?;
    c.range(
        "external_fix.random_walk_m_per_rts",
        x.random_walk_m_per_rts,
        0.0,
        MAX_FIX_RANDOM_WALK,
    )?;
    if let Some(w) = x.filter_white_m {
        c.range("external_fix.filter_white_m", w, 1e-3, 1e5)?;
    }
    if let Some(b) = x.fading_b {
        if !(b > 0.0 && b < 1.0) {
            return Err(c.err(format!(
                "external_fix.fading_b must be between 0 and 1 (exclusive), got {}",
                short_number(b)
            )));
        }
    }
    Ok(ExternalFix {
        interval_s: x.interval_s,
        white_m: x.white_m,
        random_walk_m_per_rts: x.random_walk_m_per_rts,
        filter_white_m: x.filter_white_m.unwrap_or(x.white_m),
        adaptive: x.adaptive.unwrap_or_default(),
        fading_b: x.fading_b.unwrap_or(0.95),
    })
}

/// `[filter]` with every default applied: priors and noise from the
/// simulated sensor models unless the file says otherwise (its values were
/// range-checked in `Scenario::parse`).
fn filter(file: &ScenarioFile, odometer: &OdometerModel, dt: f64) -> FilterSettings {
    let f = &file.filter;
    let imu = &file.imu;
    let rms3 = |v: [f64; 3]| ((v[0] * v[0] + v[1] * v[1] + v[2] * v[2]) / 3.0).sqrt();
    let gyro_sigma_dph = f.gyro_bias_sigma_dph.unwrap_or_else(|| {
        (rms3(imu.gyro_bias_dph).powi(2)
            + imu.gyro_bias_random_dph.powi(2)
            + imu.gyro_bias_instability_dph.powi(2))
        .sqrt()
        .max(0.001)
    });
    let accel_sigma_ug = f.accel_bias_sigma_ug.unwrap_or_else(|| {
        (rms3(imu.accel_bias_ug).powi(2)
            + imu.accel_bias_random_ug.powi(2)
            + imu.accel_bias_instability_ug.powi(2))
        .sqrt()
        .max(5.0)
    });
    let sf = odometer.scale_factor_error;
    let nav = &file.navigator;
    let ia = nav.initial_attitude_error_arcmin;
    let ias = nav.initial_attitude_sigma_arcmin;
    let [sa_level, sa_head] = f.attitude_sigma_arcmin.unwrap_or([
        ia[0].abs().max(ia[1].abs()).hypot(ias[0]).max(0.5),
        ia[2].abs().hypot(ias[1]).max(1.0),
    ]);
    let ip = nav.initial_position_error_m;
    let ips = nav.initial_position_sigma_m;
    let position_sigma_m = f.position_sigma_m.unwrap_or([
        ip[0].abs().max(ip[1].abs()).hypot(ips[0]).max(1.0),
        ip[2].abs().hypot(ips[1]).max(1.0),
    ]);
    let iv = nav.initial_velocity_error_mps;
    let velocity_sigma_mps = f.velocity_sigma_mps.unwrap_or(
        iv.iter()
            .fold(0.0f64, |a, x| a.max(x.abs()))
            .hypot(nav.initial_velocity_sigma_mps)
            .max(0.05),
    );
    let odo_t = f.odometer_interval_s.unwrap_or(0.1);
    let n = (odo_t / dt).round().max(1.0);
    let o = odometer;
    FilterSettings {
        interval_s: f.interval_s.unwrap_or(0.1),
        odometer_interval_s: odo_t,
        odometer_noise_mps: f.odometer_noise_mps.unwrap_or_else(|| {
            ((o.noise_mps * o.noise_mps / n) + (o.pulse_m / odo_t).powi(2) / 6.0 + 0.01f64.powi(2))
                .sqrt()
        }),
        nhc_noise_mps: f.nhc_noise_mps.unwrap_or(0.05),
        gyro_bias_sigma: gyro_sigma_dph * DPH,
        gyro_bias_tau_s: if imu.gyro_bias_instability_dph > 0.0 {
            imu.gyro_bias_tau_s
        } else {
            1e6
        },
        accel_bias_sigma: accel_sigma_ug * 1e-6 * G0,
        accel_bias_tau_s: if imu.accel_bias_instability_ug > 0.0 {
            imu.accel_bias_tau_s
        } else {
            1e6
        },
        // The priors cover the simulated errors: the fixed value and the
        // per-run σ (hypot(x, 0) is |x| exactly, so scenarios without the
        // per-run terms keep their priors bit for bit).
        odometer_scale_sigma: f.odometer_scale_sigma.unwrap_or(
            sf.abs()
                .hypot(odometer.scale_factor_sigma)
                .hypot(odometer.scale_factor_instability)
                .max(5e-4),
        ),
        // A random constant, or the simulated process's time when the
        // scale factor varies.
        odometer_scale_tau_s: f.odometer_scale_tau_s.unwrap_or(
            if odometer.scale_factor_instability > 0.0 {
                odometer.scale_factor_tau_s
            } else {
                1e6
            },
        ),
        odometer_misalignment_sigma: match f.odometer_misalignment_sigma_deg {
            Some(x) => x.to_radians(),
            None => {
                let [p, y] = odometer.misalignment;
                p.abs()
                    .max(y.abs())
                    .hypot(odometer.misalignment_sigma)
                    .max(0.2f64.to_radians())
            }
        },
        attitude_sigma: [sa_level * ARCMIN, sa_head * ARCMIN],
        position_sigma_m,
        velocity_sigma_mps,
    }
}
