//! One run of the stand-alone navigators (free inertial, odometer dead
//! reckoning with inertial fall-back, gyro-free 3-D dead reckoning) with its
//! own random streams.

use super::records::RunResult;
use super::truth::{body_q, initial_estimate, run_mounting, run_odometer, start_run, TruthSource};
use crate::attitude::QuatExt;
use crate::nav::{BaroDamping, Dr3d, HandoverWindow, OdometerDr, Strapdown};
use crate::scenario::{NavMode, Scenario, VerticalChannel};
use crate::sensors::odometer::wheel_distances;
use crate::sensors::rng::{ids, normal, stream};
use crate::sensors::{Barometer, DiffOdometer, Imu};

/// The window (s) of odometer travel whose mean velocity dead reckoning
/// hands to the inertial navigator when the odometer fails
/// ([`HandoverWindow`]): long enough that a pulse or the speed noise is a
/// small share of it (a 3 cm pulse is 1.5 cm/s over 2 s, 3 m/s over one
/// 10 ms step), short against the inertial navigator's own drift after it
/// (the window costs the inertial velocity error's change over 1 s, what
/// the drift adds in the first second after the failure anyway).
pub const HANDOVER_WINDOW_S: f64 = 2.0;

/// One run with its own random streams.
pub fn run_once(scn: &Scenario, truth: &TruthSource, seed: u64, run: u64) -> RunResult {
    let dt = scn.dt;
    let rot = scn.rotation;
    let (mut samples, mut rec) = start_run(scn, truth, rot);
    let Some(first) = samples.next() else {
        return RunResult::empty(run);
    };
    // Truth body attitude at the start (undo the modulation).
    let mut truth0 = first.avp.state;
    truth0.q = body_q(&first.avp.state.q, 0.0, rot);
    let mount = run_mounting(scn, seed, run);
    let mut est0 = initial_estimate(scn, &truth0, &mount);
    let est_body_q0 = est0.q;
    if let Some(r) = rot {
        est0.q = r.imu_attitude(&est0.q, 0.0);
    }
    rec.record(0, &first.avp, est0.lat, est0.lon, est0.h);
    let mut imu = Imu::new(&scn.imu, dt, stream(seed, run, ids::IMU));
    imu.mount(&mount);
    let mut baro = Barometer::new(&scn.baro, stream(seed, run, ids::BARO));
    let mut ins = Strapdown::new(est0, dt);
    let mut damping = match scn.navigator().vertical_channel {
        VerticalChannel::Baro => Some(BaroDamping::new(scn.navigator().vertical_tau_s)),
        VerticalChannel::Free => None,
    };
    let mut ins_step = |ins: &mut Strapdown, s: &crate::trajectory::TruthSample| {
        let m = imu.measure(&s.imu);
        ins.step(&m);
        if let Some(d) = damping.as_mut() {
            if let Some(hb) = baro.measure(s.avp.t, s.avp.state.h) {
                d.set_reference(hb);
            }
            d.apply(ins);
        }
    };
    let mut k = 0u64;
    match scn.navigator().mode {
        // Integrated runs go through `run_integrated`; here (direct calls of
        // `run_once`) they run free inertial.
        NavMode::FreeInertial | NavMode::Integrated => {
            for s in samples {
                k += 1;
                ins_step(&mut ins, &s);
                rec.record(k, &s.avp, ins.state.lat, ins.state.lon, ins.state.h);
            }
        }
        NavMode::DeadReckoning => {
            let mut odo = run_odometer(scn, &mount, seed, run);
            let mut dr = OdometerDr::new(est0.lat, est0.lon, est0.h);
            let mut last_distance = first.avp.distance_m;
            let mut q_prev = est_body_q0;
            let mut failed = false;
            let mut window = HandoverWindow::new(HANDOVER_WINDOW_S, dt);
            for s in samples {
                k += 1;
                let ins_v0 = ins.state.v;
                ins_step(&mut ins, &s);
                let q_now = body_q(&ins.state.q, s.avp.t, rot);
                let d_true = s.avp.distance_m - last_distance;
                last_distance = s.avp.distance_m;
                if !failed {
                    match odo.measure(s.avp.t, s.avp.distance_m, d_true, dt) {
                        Some(ds) => {
                            let d = dr.step(&q_prev, &q_now, ds);
                            window.push(d, ins_v0, ins.state.v);
                        }
                        None => {
                            // Odometer failed: continue inertially from the
                            // dead-reckoned position, moved over this step
                            // (the odometer counted up to the last one), with
                            // the odometer's velocity over the window.
                            failed = true;
                            let v = window.velocity(ins.state.v);
                            dr.shift(v * dt);
                            ins.state.lat = dr.lat;
                            ins.state.lon = dr.lon;
                            ins.state.h = dr.h;
                            ins.reset_velocity(v);
                        }
                    }
                }
                q_prev = q_now;
                if failed {
                    rec.record(k, &s.avp, ins.state.lat, ins.state.lon, ins.state.h);
                } else {
                    rec.record(k, &s.avp, dr.lat, dr.lon, dr.h);
                }
            }
        }
        NavMode::DeadReckoning3d => {
            let m = scn.diff_odometer;
            let mut wheels = DiffOdometer::new(&m, stream(seed, run, ids::DIFF_ODOMETER));
            let mut level = stream(seed, run, ids::LEVEL);
            let level_noise = scn.level_sensor_noise();
            let mut alt = Barometer::new(&scn.baro, stream(seed, run, ids::BARO));
            let (_, roll0_est, _) = est_body_q0.to_euler();
            let (_, roll0_true, _) = truth0.q.to_euler();
            let roll_bias = roll0_est - roll0_true;
            let heading0 = -est_body_q0.to_euler().2;
            let mut dr = Dr3d::new(
                est0.lat,
                est0.lon,
                est0.h,
                heading0,
                m.track_width_m + m.track_width_error_m,
            )
            // Pitch over a baseline long enough for the altimeter's noise
            // (the navigator is told the noise it is built for, as a filter
            // is told its sensors' σ).
            .with_pitch_baseline(Dr3d::baseline_for_noise(scn.baro.noise_m));
            let mut last_alt = alt.measure(first.avp.t, first.avp.state.h);
            let mut prev_truth = truth0;
            let (mut sl, mut sr) = (0.0, 0.0);
            for s in samples {
                k += 1;
                let mut tb = s.avp.state;
                tb.q = body_q(&s.avp.state.q, s.avp.t, rot);
                let (l, r) = wheel_distances(&prev_truth, &tb, m.track_width_m);
                prev_truth = tb;
                let (ml, mr) = wheels.measure(l, r, dt);
                sl += ml;
                sr += mr;
                if let Some(h) = alt.measure(s.avp.t, tb.h) {
                    let dh = last_alt.map_or(0.0, |h0| h - h0);
                    last_alt = Some(h);
                    let (_, roll_true, _) = tb.q.to_euler();
                    let roll = roll_true
                        + roll_bias
                        + if level_noise > 0.0 {
                            level_noise * normal(&mut level)
                        } else {
                            0.0
                        };
                    dr.step(sl, sr, dh, roll);
                    sl = 0.0;
                    sr = 0.0;
                }
                // Between the altimeter's readings, where the wheels have
                // taken it since the last one.
                let (lat, lon, h) = dr.position_ahead(sl, sr);
                rec.record(k, &s.avp, lat, lon, h);
            }
        }
    }
    RunResult {
        run,
        rows: rec.finish(),
        tag_events: vec![],
        tag_passes: vec![],
        counts: None,
        map_feed: None,
        calibration: None,
        calibration_rows: vec![],
    }
}
