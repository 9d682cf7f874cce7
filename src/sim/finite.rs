//! No silent non-finite results: a run whose error became NaN or infinite
//! (a navigator that diverged) is an error naming when and the scenario's
//! likely cause, before a summary is made of it (`f64::max` would skip the
//! NaN and report a maximum of 0 m).

use super::records::RunResult;
use crate::error::{Error, Result};
use crate::scenario::{NavMode, Scenario, VerticalChannel};
use crate::units::{DPH, G0};

/// Checks every run's error rows (and, for the integrated navigator, the
/// filter's σ) for NaN and infinity; the earliest such row is the error.
pub fn check_runs_finite(scn: &Scenario, runs: &[RunResult]) -> Result<()> {
    let filter = scn.navigator().mode == NavMode::Integrated;
    let first_bad = runs
        .iter()
        .filter_map(|r| {
            r.rows
                .iter()
                .find(|x| {
                    let e = [
                        x.t_s,
                        x.distance_m,
                        x.east_m,
                        x.north_m,
                        x.up_m,
                        x.horizontal_m,
                    ];
                    let s = [x.sigma_east_m, x.sigma_north_m, x.sigma_up_m, x.bound95_m];
                    e.iter().any(|v| !v.is_finite()) || (filter && s.iter().any(|v| !v.is_finite()))
                })
                .map(|x| (x.t_s, r.run))
        })
        .min_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    let Some((t, run)) = first_bad else {
        return Ok(());
    };
    let what = match scn.navigator().mode {
        NavMode::FreeInertial => "the inertial solution",
        NavMode::Integrated => "the integrated navigator's solution",
        NavMode::DeadReckoning | NavMode::DeadReckoning3d => "the dead-reckoning solution",
    };
    Err(Error::scenario(
        &scn.path,
        format!(
            "{what} diverged (NaN or infinite error) at t = {t:.1} s of run {run}: check {}",
            likely_causes(scn)
        ),
    ))
}

/// The scenario's sensor errors that are beyond any vehicle-grade sensor,
/// named as in the file, or the sections to check when none is.
fn likely_causes(scn: &Scenario) -> String {
    let imu = &scn.imu;
    let max3 = |v: [f64; 3]| v.iter().fold(0.0f64, |a, x| a.max(x.abs()));
    let ug = 1e-6 * G0;
    // (field, value in the file's unit, unit, largest plausible value)
    let fields = [
        ("gyro_bias_dph", max3(imu.gyro_bias) / DPH, "°/h", 1e4),
        ("accel_bias_ug", max3(imu.accel_bias) / ug, "µg", 1e5),
        (
            "gyro_bias_instability_dph",
            imu.gyro_bias_instability / DPH,
            "°/h",
            1e4,
        ),
        (
            "accel_bias_instability_ug",
            imu.accel_bias_instability / ug,
            "µg",
            1e5,
        ),
        (
            "gyro_arw_dprh",
            imu.gyro_arw * 60.0 / 1f64.to_radians(),
            "°/√h",
            100.0,
        ),
        ("accel_vrw_ugprhz", imu.accel_vrw / ug, "µg/√Hz", 1e5),
        (
            "gyro_bias_random_dph",
            scn.gyro_bias_random() / DPH,
            "°/h",
            1e4,
        ),
        (
            "accel_bias_random_ug",
            scn.accel_bias_random() / ug,
            "µg",
            1e5,
        ),
    ];
    let named: Vec<String> = fields
        .iter()
        .filter(|f| f.1.is_nan() || f.1 > f.3)
        .map(|(name, x, unit, _)| format!("[imu] {name} ({x:.3e} {unit})"))
        .collect();
    if named.is_empty() {
        suspect_sections(scn, scn.navigator().mode)
    } else {
        named.join(", ")
    }
}

/// The scenario's sections whose terms feed the navigator of `mode`, named
/// for a divergence none of whose terms stands out (no single section is
/// guessed): the sensors that navigator reads (the barometer only when it
/// damps the vertical channel or aids the filter), its initial errors and,
/// for the integrated navigator, the filter's settings. A route or network
/// plan's covariance analysis is the integrated navigator's.
pub fn suspect_sections(scn: &Scenario, mode: NavMode) -> String {
    let aid = scn.aiding();
    let baro_channel = scn.navigator().vertical_channel == VerticalChannel::Baro;
    let mut v = Vec::new();
    match mode {
        NavMode::FreeInertial | NavMode::DeadReckoning => {
            v.push("the [imu] error terms");
            if mode == NavMode::DeadReckoning {
                v.push("[odometer]");
            }
            if baro_channel {
                v.push("[baro]");
            }
        }
        NavMode::DeadReckoning3d => v.extend(["[diff_odometer]", "[baro]", "[level_sensor]"]),
        NavMode::Integrated => {
            v.push("the [imu] error terms");
            for (on, section) in [
                (aid.odometer, "[odometer]"),
                (aid.baro, "[baro]"),
                (aid.external_fix, "[external_fix]"),
                (aid.map_matching, "[map]"),
            ] {
                if on {
                    v.push(section);
                }
            }
        }
    }
    v.push("the [navigator] initial errors");
    if mode == NavMode::Integrated {
        v.push("the [filter] settings");
    }
    let last = v.pop().unwrap_or_default();
    if v.is_empty() {
        last.to_string()
    } else {
        format!("{} and {last}", v.join(", "))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::records::ErrorRow;

    fn row(t: f64, e: f64) -> ErrorRow {
        ErrorRow {
            t_s: t,
            distance_m: 10.0 * t,
            east_m: e,
            north_m: 0.0,
            up_m: 0.0,
            horizontal_m: e.abs(),
            sigma_east_m: f64::NAN,
            sigma_north_m: f64::NAN,
            sigma_up_m: f64::NAN,
            bound95_m: f64::NAN,
            nees_h: f64::NAN,
        }
    }

    fn run(k: u64, rows: Vec<ErrorRow>) -> RunResult {
        RunResult {
            run: k,
            rows,
            tag_events: vec![],
            tag_passes: vec![],
            counts: None,
            map_feed: None,
            calibration: None,
            calibration_rows: vec![],
        }
    }

    #[test]
    fn the_earliest_non_finite_row_is_named_with_the_likely_cause() {
        let text = r#"
name = "d"
[[route]]
start = { lat = 30.0, lon = 117.0, height_m = 0.0, heading_deg = 0.0 }
motion = [ { kind = "stay", duration_s = 10 } ]
[imu]
gyro_bias_dph = [2e5, 0, 0]
"#;
        let scn = Scenario::parse(std::path::Path::new("d.toml"), text).unwrap();
        let ok = run(0, vec![row(0.0, 0.0), row(1.0, 5.0)]);
        assert!(check_runs_finite(&scn, std::slice::from_ref(&ok)).is_ok());
        // A filter's σ is NaN without a filter: not a divergence.
        let runs = [
            ok,
            run(1, vec![row(0.0, 0.0), row(1.0, 1.0), row(2.0, f64::NAN)]),
            run(2, vec![row(0.0, 0.0), row(1.0, f64::INFINITY)]),
        ];
        let e = check_runs_finite(&scn, &runs).unwrap_err().to_string();
        assert!(
            e.starts_with("d.toml: the inertial solution diverged"),
            "{e}"
        );
        assert!(e.contains("at t = 1.0 s of run 2"), "{e}");
        assert!(e.contains("[imu] gyro_bias_dph (2.000e5 °/h)"), "{e}");
    }

    #[test]
    fn a_divergence_without_a_named_term_names_the_sections_its_navigator_reads() {
        // It blamed [imu] alone (and [filter], which only the integrated
        // navigator has), also for gyro-free 3-D dead reckoning, whose
        // divergence (e.g. [baro] noise_m = 1e308 before its limit) comes
        // from the wheels, the barometer or the level sensor.
        let scn = |extra: &str| {
            let text = format!(
                "name = \"d\"\n[[route]]\n\
                 start = {{ lat = 30.0, lon = 117.0, height_m = 0.0, heading_deg = 0.0 }}\n\
                 motion = [ {{ kind = \"stay\", duration_s = 10 }} ]\n{extra}\n"
            );
            Scenario::parse(std::path::Path::new("d.toml"), &text).unwrap()
        };
        let bad = [run(0, vec![row(0.0, 0.0), row(1.0, f64::NAN)])];
        let message = |extra: &str| {
            check_runs_finite(&scn(extra), &bad)
                .unwrap_err()
                .to_string()
        };
        let e = message("[navigator]\nmode = \"dead_reckoning_3d\"");
        assert!(
            e.ends_with(
                "check [diff_odometer], [baro], [level_sensor] and the [navigator] initial errors"
            ),
            "{e}"
        );
        // The barometer damps the inertial vertical channel by default.
        let e = message("[navigator]\nmode = \"dead_reckoning\"");
        assert!(
            e.ends_with(
                "check the [imu] error terms, [odometer], [baro] and the [navigator] initial errors"
            ),
            "{e}"
        );
        let e = message("[navigator]\nmode = \"free_inertial\"\nvertical_channel = \"free\"");
        assert!(
            e.ends_with("check the [imu] error terms and the [navigator] initial errors"),
            "{e}"
        );
        let e =
            message("[navigator]\nmode = \"integrated\"\n[aiding]\nodometer = true\nbaro = true");
        assert!(
            e.ends_with(
                "check the [imu] error terms, [odometer], [baro], the [navigator] initial errors \
                 and the [filter] settings"
            ),
            "{e}"
        );
    }
}
