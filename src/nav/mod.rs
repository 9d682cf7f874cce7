//! Navigation: strapdown inertial mechanization, vertical-channel damping and
//! dead reckoning (odometer with IMU attitude, and gyro-free 3-D).

pub mod strapdown;

pub use strapdown::{ImuIncrement, InverseStrapdown, NavState, PositionIntegrator, Strapdown};
