//! Unit constants: the one definition of each factor that converts the
//! scenario file's units (deg/h, arcmin, arcsec, µg) to SI.

/// Standard gravity (m/s²), the reference of µg.
pub const G0: f64 = 9.806_65;

/// One degree per hour in rad/s.
pub const DPH: f64 = std::f64::consts::PI / 180.0 / 3600.0;

/// One arcminute in radians.
pub const ARCMIN: f64 = std::f64::consts::PI / 180.0 / 60.0;

/// One arcsecond in radians.
pub const ARCSEC: f64 = ARCMIN / 60.0;
