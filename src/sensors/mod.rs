//! Sensor error models. Every random draw comes from a seeded generator
//! ([`rng::stream`]): the same seed gives the same output. The models are
//! re-exported here; [`rng`] stays public so that callers draw from the
//! same seeded streams.

pub(crate) mod baro;
pub(crate) mod imu;
pub(crate) mod odometer;
pub mod rng;
pub(crate) mod rotation;

pub use baro::{Barometer, BarometerModel};
pub use imu::{Imu, ImuModel};
pub use odometer::{
    DiffOdometer, DiffOdometerModel, Odometer, OdometerFailure, OdometerModel, RunMounting,
    WheelSlip,
};
pub use rotation::RotationModulation;
