//! Navigation: strapdown inertial mechanization, vertical-channel damping and
//! dead reckoning (odometer with IMU attitude, and gyro-free 3-D).

pub(crate) mod dead_reckoning;
pub(crate) mod dr3d;
pub mod ekf;
pub mod integrated;
pub(crate) mod strapdown;
pub(crate) mod vertical;

pub use dead_reckoning::OdometerDr;
pub use dr3d::Dr3d;
pub use ekf::UpdateOutcome;
pub use integrated::{Filter, FilterConfig, FixPosition, MeasurementQueue};
pub use strapdown::{ImuIncrement, InverseStrapdown, NavState, PositionIntegrator, Strapdown};
pub use vertical::BaroDamping;
