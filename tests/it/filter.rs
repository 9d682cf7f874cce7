//! The integrated navigator: the error model against the mechanization and
//! closed forms, the paper's 13-state model and odometer measurement matrix as
//! a subset of the filter's, the update machinery (time order, gating,
//! Sage–Husa weight) and the papers' experiments as scenarios.

#![allow(clippy::needless_range_loop)]

use nalgebra::{Matrix1, Matrix2, Vector1};
use std::path::Path;
use waymark::attitude::{Quat, QuatExt, M3, V3};
use waymark::geodesy::{radii, EarthState};
use waymark::nav::ekf::*;
use waymark::nav::integrated::sage_husa_weight;
use waymark::nav::{Filter, FilterConfig, MeasurementQueue, NavState, Strapdown};
use waymark::sim::{simulate, Scenario, SimResult, TruthSource};
use waymark::trajectory::{ideal_imu, Motion, MotionPlan, Start};

fn noise() -> NoiseModel {
    NoiseModel {
        gyro_arw: 0.0,
        accel_vrw: 0.0,
        gyro_bias: (1e-9, 1e12),
        accel_bias: (1e-9, 1e12),
        odo_scale: (1e-9, 1e12),
        odo_misalign: (1e-9, 1e12),
        fix_rw: 0.0,
        baro_bias: (1e-9, 1e12),
    }
}

fn run_scenario(rel: &str, runs: u64, seed: u64) -> SimResult {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join(rel);
    let scn = Scenario::load(&path).unwrap();
    let truth = TruthSource::new(&scn).unwrap();
    simulate(&scn, &truth, runs, seed).unwrap()
}

/// The RFID paper's 13 states [δvE δvN φE φN φU δλ δL ∇x ∇y εx εy εz δK_D]
/// in the filter's layout.
const PAPER: [usize; 13] = [
    DV,
    DV + 1,
    PHI,
    PHI + 1,
    PHI + 2,
    DP + 1,
    DP,
    NABLA,
    NABLA + 1,
    EPS,
    EPS + 1,
    EPS + 2,
    KOD,
];

#[test]
fn paper_13_states_are_a_strict_subset_and_odometer_rows_reduce_to_h_od() {
    // Distinct indices, all inside the filter's state, and fewer than N.
    let mut seen = std::collections::HashSet::new();
    for &i in &PAPER {
        assert!(i < N && seen.insert(i));
    }
    assert!(PAPER.len() < N && N >= 18);
    // A moving, pitched and rolled vehicle.
    let q = Quat::from_heading_pitch_roll(0.7, 0.05, -0.03);
    let speed = 15.0;
    let v = q * V3::new(0.0, speed, 0.0);
    let state = NavState {
        q,
        v,
        lat: 0.5,
        lon: 2.0,
        h: 10.0,
    };
    let f = Filter::new(state, 0.0, 0.01, FilterConfig::new(noise(), [1e-3; N]));
    let hb = f.odometer_rows(speed);
    // Project the body-frame rows into n: H_n = C_b^n H_b.
    let c = q.to_dcm();
    let mut hn = [[0.0; N]; 3];
    for r in 0..3 {
        for j in 0..N {
            hn[r][j] = (0..3).map(|k| c[(r, k)] * hb[(k, j)]).sum();
        }
    }
    // The paper's H_OD (v_D^n = v): rows E and N.
    let (ve, vn, vu) = (v[0], v[1], v[2]);
    let h_od: [[f64; 13]; 2] = [
        [
            1.0, 0.0, 0.0, vu, -vn, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, -ve,
        ],
        [
            0.0, 1.0, -vu, 0.0, ve, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, -vn,
        ],
    ];
    for r in 0..2 {
        for (p, &i) in PAPER.iter().enumerate() {
            assert!(
                (hn[r][i] - h_od[r][p]).abs() < 1e-12,
                "row {r} paper state {p}: {} vs {}",
                hn[r][i],
                h_od[r][p]
            );
        }
        // Outside the paper's states, only the vertical velocity (zero here:
        // C_b^n C_n^b = I) and the mounting misalignments (which the paper
        // does not model) may appear.
        for j in 0..N {
            if PAPER.contains(&j) || j == ATHETA || j == APSI {
                continue;
            }
            assert!(hn[r][j].abs() < 1e-12, "row {r} state {j}: {}", hn[r][j]);
        }
    }
    // The rows are the linearisation of the measurement: perturb the truth
    // by a known error state and compare z with H x.
    let phi = V3::new(2e-4, -1e-4, 3e-4);
    let dv = V3::new(0.02, -0.03, 0.01);
    let dk = 2e-3;
    let q_est = Quat::from_rotvec(-phi) * q;
    let v_est = v + dv;
    let vb = q_est.inverse_transform_vector(&v_est);
    let z = [vb[0], vb[1] - (1.0 + dk) * speed, vb[2]];
    let mut x = [0.0; N];
    x[PHI..PHI + 3].copy_from_slice(phi.as_slice());
    x[DV..DV + 3].copy_from_slice(dv.as_slice());
    x[KOD] = dk;
    for r in 0..3 {
        let hx: f64 = (0..N).map(|j| hb[(r, j)] * x[j]).sum();
        // Second-order terms: |φ| |dv| and |φ|² v, below 1e-5 m/s.
        assert!((z[r] - hx).abs() < 2e-5, "row {r}: z {} Hx {hx}", z[r]);
    }
}

/// Position error (m, east north up) of a geodetic error state.
fn pos_m(x: &[f64; N], lat: f64, h: f64) -> V3 {
    let (rm, rn) = radii(lat);
    V3::new(
        x[DP + 1] * (rn + h) * lat.cos(),
        x[DP] * (rm + h),
        x[DP + 2],
    )
}

#[test]
fn error_model_propagation_matches_the_mechanization() {
    // A 20 min drive with turns; the navigator starts with attitude, velocity
    // and position errors and its IMU has biases. The error state propagated
    // with Φ = I + F T (T = 0.1 s, F from the truth) must track the
    // mechanization's actual error: a wrong sign or a missing coupling in F
    // (e.g. the paper's M3/M7 misprints) shows as a growing mismatch.
    let dt = 0.01;
    let start = Start {
        lat: 0.6,
        lon: 2.0,
        h: 100.0,
        heading: 1.0,
        pitch: 0.0,
        roll: 0.0,
        speed_mps: 0.0,
    };
    use waymark::trajectory::Extent;
    let cmds = vec![
        Motion::ChangeSpeed {
            to_mps: 20.0,
            accel_mps2: 1.0,
            decelerate: false,
        },
        Motion::Cruise {
            extent: Extent::Duration(300.0),
        },
        Motion::Turn {
            angle: 1.5,
            radius_m: 200.0,
        },
        Motion::Cruise {
            extent: Extent::Duration(400.0),
        },
        Motion::Turn {
            angle: -2.5,
            radius_m: 150.0,
        },
        Motion::Cruise {
            extent: Extent::Duration(450.0),
        },
    ];
    let plan = MotionPlan::new(start, &cmds, dt).unwrap();
    let mut samples = ideal_imu(plan.trajectory(), dt);
    let first = samples.next().unwrap();
    let t0 = first.avp.state;
    let phi0 = V3::new(1e-4, -8e-5, 5e-4);
    let dv0 = V3::new(0.05, -0.03, 0.0);
    let dp0 = [
        3.0 / radii(t0.lat).0,
        -2.0 / (radii(t0.lat).1 * t0.lat.cos()),
        0.0,
    ];
    let eps = V3::new(
        0.02f64.to_radians() / 3600.0,
        -0.01f64.to_radians() / 3600.0,
        0.03f64.to_radians() / 3600.0,
    );
    let nab = V3::new(1e-3, -5e-4, 0.0);
    let est = NavState {
        q: Quat::from_rotvec(-phi0) * t0.q,
        v: t0.v + dv0,
        lat: t0.lat + dp0[0],
        lon: t0.lon + dp0[1],
        h: t0.h,
    };
    let mut ins = Strapdown::new(est, dt);
    let mut x = [0.0; N];
    x[PHI..PHI + 3].copy_from_slice(phi0.as_slice());
    x[DV..DV + 3].copy_from_slice(dv0.as_slice());
    x[DP] = dp0[0];
    x[DP + 1] = dp0[1];
    x[EPS..EPS + 3].copy_from_slice(eps.as_slice());
    x[NABLA..NABLA + 3].copy_from_slice(nab.as_slice());
    let nm = noise();
    let (mut acc_dv, mut acc_c, mut n) = (V3::zeros(), M3::zeros(), 0);
    let mut worst = 0.0f64;
    let mut last = (0.0, [0.0; 3], V3::zeros());
    for (k, s) in samples.enumerate() {
        let mut inc = s.imu;
        for i in 0..3 {
            inc.dtheta[i] += eps[i] * dt;
            inc.dv[i] += nab[i] * dt;
        }
        // Truth specific force and attitude over the filter interval.
        let c = s.avp.state.q.to_dcm();
        let f = s.avp.state.q * s.imu.dv;
        acc_dv += f;
        acc_c += c;
        n += 1;
        ins.step(&inc);
        ins.state.h = s.avp.state.h; // vertical channel held (both sides)
        ins.state.v[2] = s.avp.state.v[2];
        if n == 10 {
            let tr = s.avp.state;
            let m = ErrorModelInput {
                eth: EarthState::new(tr.lat, tr.h, tr.v.into()),
                v: tr.v,
                f_n: acc_dv / 0.1,
                c_bn: acc_c / 10.0,
            };
            let f = system_matrix(&m, &nm);
            let mut xn = x;
            for i in 0..N {
                xn[i] += (0..N).map(|j| f[(i, j)] * x[j]).sum::<f64>() * 0.1;
            }
            x = xn;
            x[DV + 2] = 0.0;
            x[DP + 2] = 0.0;
            acc_dv = V3::zeros();
            acc_c = M3::zeros();
            n = 0;
            let actual = [
                (ins.state.lon - tr.lon) * radii(tr.lat).1 * tr.lat.cos(),
                (ins.state.lat - tr.lat) * radii(tr.lat).0,
            ];
            let model = pos_m(&x, tr.lat, tr.h);
            let e = (actual[0] - model[0]).hypot(actual[1] - model[1]);
            let size = actual[0].hypot(actual[1]);
            worst = worst.max(e / size.max(10.0));
            last = (s.avp.t, [actual[0], actual[1], 0.0], model);
            let _ = k;
        }
    }
    let (t, a, m) = last;
    eprintln!("worst relative mismatch {worst:.4}; at {t} s actual {a:?} model {m:?}");
    // Over 20 min the errors reach a few hundred metres; first-order
    // discretisation and second-order error terms keep the model within
    // 0.5 % (measured 0.06 %; flipping the sign of f^n × φ gives 820 %).
    // Small Earth-rate and transport-rate terms hardly show here: the
    // Jacobian test below checks them entry by entry.
    assert!(t > 1190.0);
    assert!(a[0].hypot(a[1]) > 100.0, "errors too small to test: {a:?}");
    assert!(
        worst < 0.005,
        "worst relative mismatch {worst}; last actual {a:?} model {m:?}"
    );
}

#[test]
fn covariance_propagation_follows_the_schuler_closed_form() {
    // At rest, an initial tilt σ δθ about east (φ_E) gives a north position
    // σ of R δθ (1 − cos ω_s t) (Schuler); propagated with the sparse
    // Φ P Φ^T at 10 Hz for a quarter and a half Schuler period.
    let lat = 0.5f64;
    let eth = EarthState::new(lat, 0.0, [0.0; 3]);
    let g = -eth.g[2];
    let m = ErrorModelInput {
        eth,
        v: V3::zeros(),
        f_n: V3::new(0.0, 0.0, g),
        c_bn: M3::identity(),
    };
    let mut s0 = [0.0; N];
    let tilt = 1e-4;
    s0[PHI] = tilt;
    let mut cov = Covariance::new(&s0, noise());
    let (rm, rn) = radii(lat);
    let r = (rm * rn).sqrt();
    let ws = (g / r).sqrt();
    let mut t = 0.0;
    for check in [1266.0, 2532.0] {
        while t < check - 1e-9 {
            cov.propagate(&m, 0.1);
            t += 0.1;
        }
        let sn = cov.p[(DP, DP)].sqrt() * rm;
        let expect = r * tilt * (1.0 - (ws * t).cos());
        // Earth-rate couplings (Foucault) the closed form leaves out: 2 %.
        assert!(
            (sn / expect - 1.0).abs() < 0.02,
            "t {t}: σN {sn} vs {expect}"
        );
    }
}

#[test]
fn measurement_queue_releases_in_time_order() {
    let mut q = MeasurementQueue::default();
    q.push(5.0, "odo@5");
    q.push(1.0, "tag@1");
    q.push(3.0, "baro@3");
    q.push(3.0, "fix@3");
    q.push(9.0, "odo@9");
    let mut out = vec![];
    while let Some((_, x)) = q.pop_due(6.0) {
        out.push(x);
    }
    assert_eq!(out, ["tag@1", "baro@3", "fix@3", "odo@5"]);
    assert_eq!(q.len(), 1);
}

#[test]
fn gate_rejects_an_outlier_and_leaves_the_covariance_alone() {
    let mut s0 = [1e-3; N];
    s0[DP] = 5.0 / 6.4e6;
    let mut cov = Covariance::new(&s0, noise());
    let p0 = cov.p;
    let mut h = Rows::<1>::zeros();
    h[(0, DP)] = 6.4e6;
    let r = Matrix1::new(1.0);
    // σ_pos = 5 m, R = 1 m²: S ≈ 26 m²; 50 m off gives NIS ≈ 96 > 10.8.
    let (o, dx) = cov.update(&Vector1::new(50.0), &h, &r, GATE_999[0]);
    assert!(!o.accepted && o.nis > 90.0 && dx.iter().all(|x| *x == 0.0));
    assert_eq!(cov.p, p0);
    let (o, _) = cov.update(&Vector1::new(5.0), &h, &r, GATE_999[0]);
    assert!(o.accepted && o.nis < 2.0);
    assert!(cov.p[(DP, DP)] < p0[(DP, DP)]);
}

#[test]
fn sage_husa_fading_weight() {
    let b = 0.95;
    assert!((sage_husa_weight(b, 0) - 1.0).abs() < 1e-15);
    assert!((sage_husa_weight(b, 1) - 1.0 / (1.0 + b)).abs() < 1e-15);
    assert!((sage_husa_weight(b, 500) - (1.0 - b)).abs() < 1e-9);
    for k in 0..50 {
        assert!(sage_husa_weight(b, k + 1) < sage_husa_weight(b, k));
    }
}

#[test]
fn nees_is_consistent_over_100_runs() {
    // 100 runs with per-run biases and initial errors drawn from the filter's
    // prior: the run-averaged horizontal NEES (2 dof) should lie in its 95 %
    // band χ²(200)/100 ∈ [1.63, 2.41] most of the time. The average over
    // runs is strongly correlated along time (the same 100 runs), so whole
    // stretches sit together; measured on seeds 1–3: mean 1.76–1.88, 86–99 %
    // of the output times inside, none above. Required: more than 70 % inside,
    // under 10 % above (over-confidence is the failure that matters), mean in
    // [1.5, 2.5].
    let r = run_scenario("scenarios/nees-consistency.toml", 100, 1);
    let n = r.summary.nees.as_ref().expect("nees");
    assert_eq!(n.runs, 100);
    assert!(
        (n.band_95[0] - 1.63).abs() < 0.02 && (n.band_95[1] - 2.41).abs() < 0.02,
        "{:?}",
        n.band_95
    );
    assert!(n.fraction_within_band > 0.7, "{n:?}");
    assert!(n.fraction_above_band < 0.1, "{n:?}");
    assert!(n.mean > 1.5 && n.mean < 2.5, "{n:?}");
}

#[test]
fn misplaced_and_rogue_tags_are_rejected() {
    let r = run_scenario("scenarios/misplaced-tag.toml", 4, 3);
    let tags = r.summary.tags.as_ref().unwrap();
    let ids: Vec<&str> = tags
        .rejected_run0
        .iter()
        .map(|e| e.tag_id.as_str())
        .collect();
    assert_eq!(ids, ["misplaced-50m", "rogue"]);
    for run in &r.runs {
        let rejected: Vec<&str> = run
            .tag_events
            .iter()
            .filter(|e| !e.accepted)
            .map(|e| e.tag_id.as_str())
            .collect();
        assert_eq!(rejected, ["misplaced-50m", "rogue"], "run {}", run.run);
        // The five good tags (read probability 1) are all accepted.
        assert_eq!(run.tag_events.iter().filter(|e| e.accepted).count(), 5);
    }
    // Requirement 10 m held throughout (measured max 1.8 m).
    assert_eq!(r.summary.time_to_exceed_requirement_s, None);
    assert!(r.summary.max_horizontal_error_m < 10.0);
}

#[test]
fn rfid_paper_experiment() {
    // PAPERS.md §1.5, Monte Carlo (10 runs each; figures in BENCHMARKS.md
    // are from 100 runs). SINS/OD with the odometer healthy "holds 20 m for
    // about 1.5 h, then diverges": over 100 runs 54 cross 20 m, the earliest at
    // 2187 s, the median crossing at 4509 s; 93.5 % of the time within.
    // Required here: some runs cross (≥ 2 of 10), none before 0.5 h, and
    // more than 80 % of the time within 20 m.
    let od = run_scenario("scenarios/rfid-paper-integrated.toml", 10, 1);
    let crossings: Vec<f64> = od
        .summary
        .per_run
        .iter()
        .filter_map(|r| r.time_to_exceed_requirement_s)
        .collect();
    assert!(crossings.len() >= 2, "{crossings:?}");
    assert!(crossings.iter().all(|t| *t > 1800.0), "{crossings:?}");
    assert!(od.summary.fraction_within_requirement.unwrap() > 0.8);
    // Odometer failed from 3600 s: more than 100 m, and the gate disabled the
    // odometer rather than trusting zero readings.
    let fail = run_scenario("scenarios/rfid-paper-integrated-odfail.toml", 1, 1);
    assert!(fail.summary.max_horizontal_error_m > 100.0);
    let c = fail.summary.updates_run0.unwrap();
    assert!(c.odometer_disabled_epochs > 90_000, "{c:?}");
    assert!(c.odometer_rejected < 20, "{c:?}");
    // With the four tag fixes (odometer healthy): from the first fix at 5000 s
    // on, every run stays within 20 m (100 runs: at most 8.45 m in the CLI's
    // profile, sampled every 26 s); the runs that cross 20 m do so before it,
    // on odometer-aided drift alone.
    let tags = run_scenario("scenarios/rfid-paper-integrated-tags.toml", 10, 1);
    for r in &tags.runs {
        let after = r
            .rows
            .iter()
            .filter(|x| x.t_s > 5001.0)
            .map(|x| x.horizontal_m)
            .fold(0.0, f64::max);
        assert!(after < 20.0, "run {}: {after} m after the first fix", r.run);
    }
    for r in &tags.summary.per_run {
        if let Some(t) = r.time_to_exceed_requirement_s {
            assert!(t < 5000.0, "run {} crosses at {t}", r.run);
        }
    }
    assert_eq!(tags.summary.tags.as_ref().unwrap().accepted, 40);
    assert!(tags.summary.duration_s > 12_800.0 && tags.summary.distance_m > 290_000.0);
}

#[test]
fn dr3d_paper_sins_dr_at_50_minutes() {
    // PAPERS.md §2.1, SINS/DR at 50 min: E 17.9, N 24.2, U 9.4 m (horizontal
    // 30.1 m). The error here is the uncorrected 2' heading error laid across
    // the track and the altimeter's 0.3 % scale error; accepted within ±50 %
    // of the paper's horizontal and vertical figures (measured 25.0 m, 7.8 m).
    let r = run_scenario("scenarios/dr3d-paper-integrated.toml", 1, 1);
    let row = r.runs[0]
        .rows
        .iter()
        .find(|x| (x.t_s - 3000.0).abs() < 0.5)
        .unwrap();
    let h = row.horizontal_m;
    assert!((15.0..45.0).contains(&h), "horizontal {h}");
    assert!((4.7..14.1).contains(&row.up_m.abs()), "up {}", row.up_m);
    // Better than the paper's DR alone (29.1, 48.2 m: 56.3 m horizontal).
    assert!(h < 56.3);
}

#[test]
fn gravity_matching_sage_husa_against_standard() {
    // Fixes every 10–50 s with random-walk + white error (20 m) the filter
    // believes is 5 m. The standard filter's gate rejects most fixes and it
    // drifts (measured: 86 of 125 rejected in run 0, 2.6 km worst over 20
    // runs); Sage–Husa re-estimates the noise and keeps every fix (measured
    // 57 m max in run 0, 79 m over 20 runs; the paper: ±48.2 m).
    let std = run_scenario("scenarios/gravity-matching-standard.toml", 4, 1);
    let sh = run_scenario("scenarios/gravity-matching-sage-husa.toml", 4, 1);
    let cs = std.summary.updates_run0.unwrap();
    let ch = sh.summary.updates_run0.unwrap();
    assert!(cs.external_rejected > cs.external_accepted / 2, "{cs:?}");
    assert_eq!(ch.external_rejected, 0, "{ch:?}");
    assert!(
        sh.summary.max_horizontal_error_m < 120.0,
        "{}",
        sh.summary.max_horizontal_error_m
    );
    assert!(std.summary.max_horizontal_error_m > 2.0 * sh.summary.max_horizontal_error_m);
    // Height from the baro (2 m noise): within the paper's ±11.5 m.
    for run in &sh.runs {
        assert!(run.rows.iter().all(|x| x.up_m.abs() < 11.5));
    }
}

#[test]
fn same_seed_same_monte_carlo() {
    let a = run_scenario("scenarios/misplaced-tag.toml", 3, 9);
    let b = run_scenario("scenarios/misplaced-tag.toml", 3, 9);
    assert_eq!(a.summary, b.summary);
    let c = run_scenario("scenarios/misplaced-tag.toml", 3, 10);
    assert_ne!(
        a.summary.rms_horizontal_error_m,
        c.summary.rms_horizontal_error_m
    );
}

#[test]
fn error_model_blocks_are_the_jacobians_of_the_navigation_equations() {
    // The position, velocity and attitude-rate blocks of F (Mpv, Mpp, Mvv,
    // Mvp, Mav, Map: where the RFID paper's M3 and M7 misprint v_E for v_N)
    // against central differences of the navigation equations
    //   ṗ = (v_N/(R_M+h), v_E/((R_N+h) cos L), v_U),
    //   v̇ = f − (2ω_ie + ω_en) × v + g,   δω_in = ω_in(est) − ω_in(true),
    // at a fast vehicle (300 m/s east, −200 m/s north) so that every term is
    // large enough to see.
    let (lat, h) = (0.7f64, 500.0);
    let v = V3::new(300.0, -200.0, 5.0);
    let eth = EarthState::new(lat, h, v.into());
    let m = ErrorModelInput {
        eth,
        v,
        f_n: V3::new(0.0, 0.0, 9.8),
        c_bn: M3::identity(),
    };
    let f = system_matrix(&m, &noise());
    // State → (position rate, velocity rate without f, ω_in).
    // The standard model holds the radii of curvature R_M, R_N constant
    // (their change with latitude is of order e² and is dropped), so they
    // are frozen here too.
    let (rm0, rn0) = radii(lat);
    let eval = |lat: f64, h: f64, v: V3| -> [f64; 9] {
        let w = waymark::geodesy::EARTH_RATE;
        let (rm, rn) = (rm0 + h, rn0 + h);
        let wie = [0.0, w * lat.cos(), w * lat.sin()];
        let wen = [-v[1] / rm, v[0] / rn, v[0] * lat.tan() / rn];
        let a = V3::new(
            2.0 * wie[0] + wen[0],
            2.0 * wie[1] + wen[1],
            2.0 * wie[2] + wen[2],
        );
        let g = waymark::geodesy::normal_gravity(lat, h);
        let cor = a.cross(&v);
        [
            v[1] / rm,
            v[0] / (rn * lat.cos()),
            v[2],
            -cor[0],
            -cor[1],
            -g - cor[2],
            wie[0] + wen[0],
            wie[1] + wen[1],
            wie[2] + wen[2],
        ]
    };
    // Rows of F: δL̇, δλ̇, δḣ at DP; δv̇ at DV; φ̇ at PHI (δω_in part only).
    let rows = [
        DP,
        DP + 1,
        DP + 2,
        DV,
        DV + 1,
        DV + 2,
        PHI,
        PHI + 1,
        PHI + 2,
    ];
    let mut worst = 0.0f64;
    for (col, step) in [
        (DV, 1e-3),
        (DV + 1, 1e-3),
        (DV + 2, 1e-3),
        (DP, 1e-7),
        (DP + 2, 1e-2),
    ] {
        let (mut a, mut b) = ((lat, h, v), (lat, h, v));
        match col {
            c if (DV..DV + 3).contains(&c) => {
                a.2[c - DV] += step;
                b.2[c - DV] -= step;
            }
            c if c == DP => {
                a.0 += step;
                b.0 -= step;
            }
            _ => {
                a.1 += step;
                b.1 -= step;
            }
        }
        let (ea, eb) = (eval(a.0, a.1, a.2), eval(b.0, b.1, b.2));
        for (k, &row) in rows.iter().enumerate() {
            let num = (ea[k] - eb[k]) / (2.0 * step);
            let ana = f[(row, col)];
            // The φ rows hold +∂ω_in; the others +∂(rate).
            let scale = num.abs().max(ana.abs()).max(1e-12);
            let rel = (num - ana).abs() / scale;
            let tiny = num.abs().max(ana.abs()) < 1e-12;
            assert!(
                tiny || rel < 1e-4,
                "F[{row}][{col}]: analytic {ana:e}, numerical {num:e}"
            );
            if !tiny {
                worst = worst.max(rel);
            }
        }
    }
    // Longitude appears nowhere in the equations: its column is zero.
    for &row in &rows {
        assert_eq!(f[(row, DP + 1)], 0.0);
    }
    eprintln!("worst relative difference {worst:e}");
}

#[test]
fn odometer_without_constraints_observes_the_forward_speed_alone() {
    // Level, heading north at 10 m/s; velocity σ 1 m/s per axis, every
    // other state σ 1e-6 (so no other state shares the update). One
    // odometer update is then a scalar Kalman update on each velocity axis
    // it observes: σ² r/(σ² + r). Forward (north) with r = σ_odo²; with the
    // constraints also east and up with r = σ_nhc²; without them (aiding
    // non_holonomic = false) east and up keep σ = 1 m/s: the rows are not
    // applied (they were, whatever the setting). Tolerance 1e-6 m²/s²: the
    // covariance is propagated over the one 10 ms step first (Coriolis and
    // transport couplings of order 1e-4 × 0.01 on the velocity block).
    let state = NavState {
        q: Quat::from_heading_pitch_roll(0.0, 0.0, 0.0),
        v: V3::new(0.0, 10.0, 0.0),
        lat: 0.5,
        lon: 2.0,
        h: 0.0,
    };
    let mut s0 = [1e-6; N];
    for k in 0..3 {
        s0[DV + k] = 1.0;
    }
    let variances = |use_nhc: bool| {
        let mut cfg = FilterConfig::new(noise(), s0);
        cfg.use_nhc = use_nhc;
        let (so, sn) = (cfg.odo_noise_mps, cfg.nhc_noise_mps);
        let mut f = Filter::new(state, 0.0, 0.01, cfg);
        let g = waymark::geodesy::normal_gravity(0.5, 0.0);
        f.step(&waymark::nav::ImuIncrement {
            dtheta: V3::zeros(),
            dv: V3::new(0.0, 0.0, g * 0.01),
        });
        let o = f.update_odometer(0.1);
        let p = f.covariance();
        let var = [p[(DV, DV)], p[(DV + 1, DV + 1)], p[(DV + 2, DV + 2)]];
        (o, var, so * so, sn * sn)
    };
    let post = |r: f64| r / (1.0 + r);
    let (o, var, ro, _) = variances(false);
    assert!(o.accepted && o.dof == 1, "{o:?}");
    assert!((var[0] - 1.0).abs() < 1e-6, "east {}", var[0]);
    assert!((var[1] - post(ro)).abs() < 1e-6, "north {}", var[1]);
    assert!((var[2] - 1.0).abs() < 1e-6, "up {}", var[2]);
    let (o, var, ro, rn) = variances(true);
    assert!(o.accepted && o.dof == 3, "{o:?}");
    assert!((var[0] - post(rn)).abs() < 1e-6, "east {}", var[0]);
    assert!((var[1] - post(ro)).abs() < 1e-6, "north {}", var[1]);
    assert!((var[2] - post(rn)).abs() < 1e-6, "up {}", var[2]);
}

#[test]
fn anisotropic_position_fix_tightens_across_the_road_only() {
    // The map-matching fix: σ 0.5 m across the road (east, the road runs
    // north), 50 m along it. The cross-road σ must drop to about 0.5 m, the
    // along-road σ hardly move; a fix stamped 0.5 s in the past is compared
    // with the navigator's position then (no 10 m innovation from the lag).
    let q = Quat::from_heading_pitch_roll(0.0, 0.0, 0.0);
    let v = V3::new(0.0, 20.0, 0.0);
    let state = NavState {
        q,
        v,
        lat: 0.8,
        lon: 0.3,
        h: 0.0,
    };
    let mut s0 = [1e-6; N];
    let (rm, rn) = radii(0.8);
    s0[DP] = 10.0 / rm;
    s0[DP + 1] = 10.0 / (rn * 0.8f64.cos());
    s0[DP + 2] = 5.0;
    let mut f = Filter::new(state, 100.0, 0.01, FilterConfig::new(noise(), s0));
    let before = f.position_cov_enu();
    // The truth 0.5 s ago was 10 m south of the navigator's current position.
    let o = f.update_position_fix(
        99.5,
        waymark::nav::FixPosition::Geodetic {
            lat: 0.8 - 10.0 / rm,
            lon: 0.3,
        },
        waymark::nav::integrated::along_across_covariance(0.0, 50.0, 0.5),
    );
    assert!(o.accepted && o.dof == 2 && o.nis < 1e-6, "{o:?}");
    // The helper rotates: heading east puts the loose axis east.
    let c =
        waymark::nav::integrated::along_across_covariance(std::f64::consts::FRAC_PI_2, 50.0, 0.5);
    assert!(
        (c[(0, 0)] - 2500.0).abs() < 1e-9
            && (c[(1, 1)] - 0.25).abs() < 1e-9
            && c[(0, 1)].abs() < 1e-9
    );
    let c =
        waymark::nav::integrated::along_across_covariance(std::f64::consts::FRAC_PI_4, 2.0, 1.0);
    assert!((c[(0, 1)] - 1.5).abs() < 1e-12 && (c[(0, 0)] - 2.5).abs() < 1e-12);
    let after = f.position_cov_enu();
    assert!((before[0][0].sqrt() - 10.0).abs() < 1e-6);
    assert!(after[0][0].sqrt() < 0.5, "east σ {}", after[0][0].sqrt());
    assert!(after[1][1].sqrt() > 9.0, "north σ {}", after[1][1].sqrt());
    // A tag fix with a height feeds the vertical channel.
    let o = f.update_position(
        100.0,
        0.8,
        0.3,
        Some(1.0),
        Matrix2::new(0.25, 0.0, 0.0, 0.25),
        0.01,
    );
    assert!(o.accepted && o.dof == 3);
    let c = f.position_cov_enu();
    assert!(c[2][2].sqrt() < 0.11 && c[1][1].sqrt() < 0.5, "{c:?}");
    // The same fix in a local ENU frame gives the same geodetic position.
    let mut g = Filter::new(state, 100.0, 0.01, FilterConfig::new(noise(), s0));
    let o2 = g.update_position_fix(
        100.0,
        waymark::nav::FixPosition::Enu {
            origin_lat: 0.8,
            origin_lon: 0.3 - 100.0 / (rn * 0.8f64.cos()),
            east: 103.0,
            north: 0.0,
        },
        Matrix2::new(0.25, 0.0, 0.0, 2500.0),
    );
    assert!(o2.accepted);
    let e = (g.state().lon - 0.3) * rn * 0.8f64.cos();
    assert!((e - 3.0).abs() < 0.1, "moved east by {e}");
}

#[test]
fn tags_are_read_only_within_their_mounting_geometry() {
    use waymark::sim::find_passes;
    use waymark::sim::tags::{Mounting, RfidModel, Tag};
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenarios/nees-consistency.toml");
    let scn = Scenario::load(&path).unwrap();
    let truth = TruthSource::new(&scn).unwrap();
    // The truth at 90 s (on a straight, heading 20°).
    let a = truth.samples().find(|a| a.t >= 90.0).unwrap().state;
    let (rm, rn) = radii(a.lat);
    let right = [20f64.to_radians().cos(), -(20f64.to_radians().sin())];
    let tag_at = |lateral: f64, m: Mounting| Tag {
        id: format!("{m:?}@{lateral}"),
        lat: a.lat + lateral * right[1] / rm,
        lon: a.lon + lateral * right[0] / (rn * a.lat.cos()),
        height_m: None,
        mounting: m,
        survey_error_m: [0.0, 0.0],
        lane_width_m: None,
    };
    let tags = vec![
        tag_at(0.3, Mounting::RoadSurface),
        tag_at(3.0, Mounting::RoadSurface),
        tag_at(6.0, Mounting::Roadside),
        tag_at(-15.0, Mounting::Roadside),
        tag_at(1.0, Mounting::Ceiling),
    ];
    let rfid = RfidModel::default();
    let passes = find_passes(&truth, 1e9, &tags, &rfid);
    let mut read: Vec<usize> = passes.iter().map(|p| p.tag).collect();
    read.sort();
    // Under the vehicle (0.3 m), a roadside post 6 m away (range 10 m) and
    // the ceiling reader over the lane: read; 3 m off for a road-surface
    // reader and 15 m for a roadside one: not.
    assert_eq!(read, [0, 2, 4]);
    for p in &passes {
        assert!((p.t_abeam - 90.0).abs() < 0.05, "{p:?}");
        assert!(
            (p.lateral_m - [0.3, 3.0, 6.0, -15.0, 1.0][p.tag]).abs() < 0.05,
            "{p:?}"
        );
    }
}

#[test]
fn odometer_slip_is_detected_from_the_innovations() {
    // 20 % over-count for 30 m, 2 events per km, on the nees-consistency
    // drive (8.8 km): the slipping readings fail the gate and the odometer
    // is disabled until its innovations pass again (run 0: 36 rejected, 492
    // epochs disabled); the error stays at the no-slip level (measured max
    // 1.98 m vs 2.03 m without slip) instead of taking the 12 m per km
    // (2 events × 30 m × 20 %) an unchecked over-count would add between tags.
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenarios/nees-consistency.toml");
    let text = std::fs::read_to_string(&path).unwrap();
    let slip = text.replace(
        "pulse_m = 0.0",
        "pulse_m = 0.0\nslip = { rate_per_km = 2.0, length_m = 30.0, overcount = 0.2 }",
    );
    assert_ne!(slip, text);
    let run = |t: &str| {
        let scn = Scenario::parse(&path, t).unwrap();
        let truth = TruthSource::new(&scn).unwrap();
        simulate(&scn, &truth, 2, 4).unwrap()
    };
    let clean = run(&text);
    let slipping = run(&slip);
    let c = slipping.summary.updates_run0.unwrap();
    eprintln!(
        "slip: max {:.2} m, clean: max {:.2} m, {c:?}",
        slipping.summary.max_horizontal_error_m, clean.summary.max_horizontal_error_m
    );
    assert!(c.odometer_rejected > 20, "{c:?}");
    assert_eq!(clean.summary.updates_run0.unwrap().odometer_rejected, 0);
    assert!(
        slipping.summary.max_horizontal_error_m < 1.5 * clean.summary.max_horizontal_error_m + 0.5,
        "slip {} clean {}",
        slipping.summary.max_horizontal_error_m,
        clean.summary.max_horizontal_error_m
    );
}

#[test]
fn tag_fix_errors_follow_the_mounting_models() {
    // PAPERS.md §1.1: roadside, D = 3.75 m, d = 3 m, θ = 15°, t0 = 20 ms,
    // 40 km/h, x = 5.63 m: dx = 0.375 m, dy = x tan θ − v t0 = 1.286 m,
    // dr = 1.340 m (the paper: 0.375, 1.285, 1.338). Road surface ≤ 0.5 m,
    // ceiling ≤ 0.3 m. The error of a read is the reported point minus where
    // the vehicle is at the read time.
    use waymark::sim::tags::{Mounting, RfidModel, Tag};
    use waymark::sim::{draw_reads, TagPass};
    let rfid = RfidModel {
        lane_width_m: 3.75,
        vehicle_width_m: 3.0,
        read_probability: 1.0,
        ..Default::default()
    };
    let v = 40.0 / 3.6;
    let (dy, sx) = rfid.fix_sigmas(Mounting::Roadside, v);
    assert!((dy - 1.2863).abs() < 1e-3, "dy {dy}");
    assert!((sx - 0.375 / 3f64.sqrt()).abs() < 1e-9);
    let (lat0, lon0) = (0.6, 0.2);
    let (rm, rn) = radii(lat0);
    let mut worst = [0.0f64; 3];
    for (k, m) in [Mounting::Roadside, Mounting::RoadSurface, Mounting::Ceiling]
        .into_iter()
        .enumerate()
    {
        let tags = vec![Tag {
            id: "t".into(),
            lat: lat0,
            lon: lon0,
            height_m: None,
            mounting: m,
            survey_error_m: [0.0, 0.0],
            lane_width_m: None,
        }];
        // Heading north, abeam the tag at t = 100 s.
        let passes: Vec<TagPass> = (0..2000)
            .map(|_| TagPass {
                tag: 0,
                t_abeam: 100.0,
                speed_mps: v,
                lateral_m: 0.0,
                forward_en: [0.0, 1.0],
            })
            .collect();
        let mut rng = waymark::sensors::rng::stream(3, 0, 7);
        let reads = draw_reads(&passes, &tags, &rfid, &mut rng);
        assert_eq!(reads.len(), 2000);
        let mut max_lat = 0.0f64;
        for r in &reads {
            let east = (r.lon - lon0) * rn * lat0.cos();
            let north = (r.lat - lat0) * rm;
            // The vehicle at the read time, from the abeam point.
            let veh_north = v * (r.t - 100.0);
            let err = [east, north - veh_north];
            let e = err[0].hypot(err[1]);
            worst[k] = worst[k].max(e);
            max_lat = max_lat.max(err[0].abs());
            if m == Mounting::Roadside {
                // The vehicle is behind the stored point by x tan θ − v t0
                // with x = 5.63 − dx, dx within ±0.375 m.
                let lo = (5.63 - 0.375) * 15f64.to_radians().tan() - v * 0.02;
                let hi = (5.63 + 0.375) * 15f64.to_radians().tan() - v * 0.02;
                assert!(err[1] > lo - 1e-6 && err[1] < hi + 1e-6, "{err:?}");
            }
        }
        if m == Mounting::Roadside {
            assert!(max_lat <= 0.375 + 1e-9 && max_lat > 0.35, "{max_lat}");
        }
    }
    // With x = 5.63 ± 0.375 m (the vehicle's place in its lane moves the
    // reader), dy reaches 6.005 tan 15° − v t0 = 1.387 m: dr ≤ 1.437 m.
    let hi = (5.63 + 0.375) * 15f64.to_radians().tan() - v * 0.02;
    let bound = 0.375f64.hypot(hi);
    assert!(
        worst[0] <= bound + 1e-6 && worst[0] > 1.3,
        "roadside {} vs {bound}",
        worst[0]
    );
    assert!(
        worst[1] <= 0.5 + 1e-9 && worst[1] > 0.4,
        "road surface {}",
        worst[1]
    );
    assert!(
        worst[2] <= 0.3 + 1e-9 && worst[2] > 0.25,
        "ceiling {}",
        worst[2]
    );
}
