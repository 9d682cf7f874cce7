//! Navigation: strapdown inertial mechanization, vertical-channel damping and
//! dead reckoning (odometer with IMU attitude, and gyro-free 3-D).
//!
//! The navigators' types are re-exported here; [`ekf`] (the filter's state
//! indices and Kalman step) and [`integrated`] (the 21-state filter and its
//! helpers) stay public so that the filter's internals can be checked from
//! outside the crate.

pub(crate) mod dead_reckoning;
pub(crate) mod dr3d;
pub mod ekf;
pub mod integrated;
pub mod riccati;
pub(crate) mod strapdown;
pub(crate) mod vertical;

pub use dead_reckoning::{HandoverWindow, OdometerDr};
pub use dr3d::Dr3d;
pub use ekf::UpdateOutcome;
pub use integrated::{Filter, FilterConfig, FixPosition, MeasurementQueue};
pub use strapdown::{ImuIncrement, InverseStrapdown, NavState, PositionIntegrator, Strapdown};
pub use vertical::BaroDamping;
