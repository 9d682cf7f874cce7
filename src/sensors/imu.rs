//! IMU error model: constant bias, bias instability (first-order Gauss–Markov),
//! angle and velocity random walk, scale factor and axis misalignment, applied
//! to ideal increments in the IMU frame.

use super::rng::{normal, GaussMarkov};
use crate::attitude::{M3, V3};
use crate::nav::ImuIncrement;
use rand_chacha::ChaCha8Rng;

/// The error parameters of a gyro and accelerometer triad, in SI units.
/// Per-axis parameters are plain arrays (x, y, z), as a scenario states them.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct ImuModel {
    /// Constant gyro bias per axis (rad/s).
    pub gyro_bias: [f64; 3],
    /// Constant accelerometer bias per axis (m/s²).
    pub accel_bias: [f64; 3],
    /// Gyro bias instability: Gauss–Markov standard deviation (rad/s).
    pub gyro_bias_instability: f64,
    /// Gyro bias correlation time (s).
    pub gyro_bias_tau_s: f64,
    /// Accelerometer bias instability: Gauss–Markov standard deviation (m/s²).
    pub accel_bias_instability: f64,
    /// Accelerometer bias correlation time (s).
    pub accel_bias_tau_s: f64,
    /// Angle random walk (rad/√s).
    pub gyro_arw: f64,
    /// Velocity random walk (m/s/√s).
    pub accel_vrw: f64,
    /// Gyro scale-factor errors per axis (ratio).
    pub gyro_scale_factor: [f64; 3],
    /// Accelerometer scale-factor errors per axis (ratio).
    pub accel_scale_factor: [f64; 3],
    /// Gyro misalignment, the off-diagonal terms xy, xz, yx, yz, zx, zy (rad).
    pub gyro_misalignment: [f64; 6],
    /// Accelerometer misalignment, as for the gyros (rad).
    pub accel_misalignment: [f64; 6],
}

impl ImuModel {
    /// Whether every error term is zero: a perfect IMU (what a scenario
    /// gets with no `[imu]` grade and no error fields).
    pub fn is_error_free(&self) -> bool {
        let zero = |v: &[f64]| v.iter().all(|x| *x == 0.0);
        zero(&self.gyro_bias)
            && zero(&self.accel_bias)
            && zero(&[
                self.gyro_bias_instability,
                self.accel_bias_instability,
                self.gyro_arw,
                self.accel_vrw,
            ])
            && zero(&self.gyro_scale_factor)
            && zero(&self.accel_scale_factor)
            && zero(&self.gyro_misalignment)
            && zero(&self.accel_misalignment)
    }
}

/// Error matrix I + diag(s) + M with M from the six off-diagonal terms.
fn error_matrix(s: [f64; 3], m: [f64; 6]) -> M3 {
    #[rustfmt::skip]
    let e = M3::new(
        1.0 + s[0], m[0], m[1],
        m[2], 1.0 + s[1], m[3],
        m[4], m[5], 1.0 + s[2],
    );
    e
}

/// A simulated IMU.
#[derive(Debug, Clone)]
pub struct Imu {
    dt: f64,
    gyro_m: M3,
    accel_m: M3,
    gyro_bias_dt: V3,
    accel_bias_dt: V3,
    arw: f64,
    vrw: f64,
    gyro_gm: [GaussMarkov; 3],
    accel_gm: [GaussMarkov; 3],
    rng: ChaCha8Rng,
}

impl Imu {
    /// An IMU sampling at interval `dt` (s) with its own random stream.
    pub fn new(model: &ImuModel, dt: f64, mut rng: ChaCha8Rng) -> Self {
        let mk = |s: f64, tau: f64, rng: &mut ChaCha8Rng| {
            [
                GaussMarkov::new(s, tau, dt, Some(rng)),
                GaussMarkov::new(s, tau, dt, Some(rng)),
                GaussMarkov::new(s, tau, dt, Some(rng)),
            ]
        };
        let gyro_gm = mk(model.gyro_bias_instability, model.gyro_bias_tau_s, &mut rng);
        let accel_gm = mk(
            model.accel_bias_instability,
            model.accel_bias_tau_s,
            &mut rng,
        );
        Self {
            dt,
            gyro_m: error_matrix(model.gyro_scale_factor, model.gyro_misalignment),
            accel_m: error_matrix(model.accel_scale_factor, model.accel_misalignment),
            gyro_bias_dt: V3::from(model.gyro_bias) * dt,
            accel_bias_dt: V3::from(model.accel_bias) * dt,
            arw: model.gyro_arw * dt.sqrt(),
            vrw: model.accel_vrw * dt.sqrt(),
            gyro_gm,
            accel_gm,
            rng,
        }
    }

    /// Mounts the IMU on the vehicle whose ideal increments
    /// [`Self::measure`] is given, rotated by the run's misalignment
    /// ([`RunMounting::vehicle_to_imu`], `C_v^s`): every increment is first
    /// resolved in the IMU's axes, then takes the triad's errors. Without a
    /// misalignment nothing changes.
    ///
    /// [`RunMounting::vehicle_to_imu`]: super::RunMounting::vehicle_to_imu
    pub fn mount(&mut self, mounting: &super::RunMounting) {
        if let Some(q) = mounting.vehicle_to_imu() {
            let c = q.to_rotation_matrix().into_inner();
            self.gyro_m *= c;
            self.accel_m *= c;
        }
    }

    /// The measured increments for ideal increments `ideal`.
    #[inline]
    pub fn measure(&mut self, ideal: &ImuIncrement) -> ImuIncrement {
        let mut dtheta = self.gyro_m * ideal.dtheta;
        let mut dv = self.accel_m * ideal.dv;
        for i in 0..3 {
            dtheta[i] += self.gyro_bias_dt[i] + self.gyro_gm[i].step(&mut self.rng) * self.dt;
            dv[i] += self.accel_bias_dt[i] + self.accel_gm[i].step(&mut self.rng) * self.dt;
        }
        if self.arw > 0.0 {
            for d in dtheta.iter_mut() {
                *d += self.arw * normal(&mut self.rng);
            }
        }
        if self.vrw > 0.0 {
            for d in dv.iter_mut() {
                *d += self.vrw * normal(&mut self.rng);
            }
        }
        ImuIncrement { dtheta, dv }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sensors::rng::stream;

    #[test]
    fn constant_errors_are_applied_exactly() {
        let model = ImuModel {
            gyro_bias: [1e-5, 0.0, 0.0],
            accel_bias: [0.0, 1e-3, 0.0],
            gyro_scale_factor: [0.0, 0.0, 1e-3],
            accel_misalignment: [0.0, 0.0, 0.0, 0.0, 0.0, 1e-3],
            ..Default::default()
        };
        let mut imu = Imu::new(&model, 0.01, stream(1, 0, 1));
        let m = imu.measure(&ImuIncrement {
            dtheta: V3::new(0.0, 0.0, 0.1),
            dv: V3::new(0.0, 0.098, 0.0),
        });
        assert!((m.dtheta[0] - 1e-7).abs() < 1e-20);
        assert!((m.dtheta[2] - 0.1001).abs() < 1e-15);
        assert!((m.dv[1] - (0.098 + 1e-5)).abs() < 1e-15);
        assert!((m.dv[2] - 0.098e-3).abs() < 1e-15);
    }

    #[test]
    fn angle_random_walk_has_the_stated_density() {
        // Summed angle after n samples has σ = ARW √(n dt); over 1000 independent
        // 10 s sums the sample σ is within ±10 % (its relative σ is 2.2 %).
        let arw = 1e-4;
        let model = ImuModel {
            gyro_arw: arw,
            ..Default::default()
        };
        let mut imu = Imu::new(&model, 0.01, stream(3, 0, 1));
        let mut s2 = 0.0;
        for _ in 0..1000 {
            let mut a = 0.0;
            for _ in 0..1000 {
                a += imu.measure(&ImuIncrement::default()).dtheta[0];
            }
            s2 += a * a;
        }
        let sigma = (s2 / 1000.0).sqrt();
        let expect = arw * 10f64.sqrt();
        assert!((sigma / expect - 1.0).abs() < 0.1, "{sigma} vs {expect}");
    }

    #[test]
    fn a_mounted_imu_measures_the_vehicles_increments_in_its_own_axes() {
        let mounting = crate::sensors::RunMounting {
            scale_factor_error: 0.0,
            misalignment: [0.004, -0.01],
        };
        let c = mounting.vehicle_to_imu().unwrap();
        let mut imu = Imu::new(
            &ImuModel::default(),
            0.01,
            rand::SeedableRng::seed_from_u64(1),
        );
        imu.mount(&mounting);
        let ideal = ImuIncrement {
            dtheta: V3::new(1e-4, -2e-4, 3e-3),
            dv: V3::new(0.01, 0.1, 0.098),
        };
        let m = imu.measure(&ideal);
        assert!((m.dtheta - c * ideal.dtheta).norm() < 1e-18);
        assert!((m.dv - c * ideal.dv).norm() < 1e-16);
    }
}
