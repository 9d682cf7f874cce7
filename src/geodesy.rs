//! WGS-84 geodesy: ellipsoid constants, radii of curvature, normal gravity and
//! conversions between geodetic coordinates, Earth-centred Earth-fixed (ECEF)
//! coordinates and a local East-North-Up (ENU) frame.
//!
//! Angles are radians unless a name says `_deg`; lengths are metres.

/// WGS-84 semi-major axis a (m).
pub const WGS84_A: f64 = 6_378_137.0;
/// WGS-84 flattening f.
pub const WGS84_F: f64 = 1.0 / 298.257_223_563;
/// WGS-84 semi-minor axis b = a (1 - f) (m).
pub const WGS84_B: f64 = WGS84_A * (1.0 - WGS84_F);
/// First eccentricity squared e² = f (2 - f).
pub const WGS84_E2: f64 = WGS84_F * (2.0 - WGS84_F);
/// Earth rotation rate ω_ie (rad/s).
pub const EARTH_RATE: f64 = 7.292_115e-5;
/// Earth's gravitational constant GM (m³/s²).
pub const WGS84_GM: f64 = 3.986_004_418e14;
/// Normal gravity at the equator γ_e (m/s²).
pub const GAMMA_EQUATOR: f64 = 9.780_325_335_9;
/// Normal gravity at the pole γ_p (m/s²).
pub const GAMMA_POLE: f64 = 9.832_184_937_8;
/// Somigliana's constant k = (b γ_p − a γ_e) / (a γ_e).
pub const SOMIGLIANA_K: f64 = 0.001_931_852_652_41;

/// A geodetic position on the WGS-84 ellipsoid.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Geodetic {
    /// Latitude L (rad), positive north.
    pub lat: f64,
    /// Longitude λ (rad), positive east.
    pub lon: f64,
    /// Height above the ellipsoid h (m).
    pub height: f64,
}

impl Geodetic {
    /// Position from degrees and metres.
    pub fn from_degrees(lat_deg: f64, lon_deg: f64, height_m: f64) -> Self {
        Self {
            lat: lat_deg.to_radians(),
            lon: lon_deg.to_radians(),
            height: height_m,
        }
    }

    /// Latitude in degrees.
    pub fn lat_deg(&self) -> f64 {
        self.lat.to_degrees()
    }

    /// Longitude in degrees.
    pub fn lon_deg(&self) -> f64 {
        self.lon.to_degrees()
    }
}

/// Meridian radius of curvature R_M at latitude `lat` (rad).
pub fn meridian_radius(lat: f64) -> f64 {
    let s = lat.sin();
    let w2 = 1.0 - WGS84_E2 * s * s;
    WGS84_A * (1.0 - WGS84_E2) / (w2 * w2.sqrt())
}

/// Prime-vertical radius of curvature R_N at latitude `lat` (rad).
pub fn prime_vertical_radius(lat: f64) -> f64 {
    let s = lat.sin();
    WGS84_A / (1.0 - WGS84_E2 * s * s).sqrt()
}

/// Both radii (R_M, R_N) at latitude `lat` (rad).
pub fn radii(lat: f64) -> (f64, f64) {
    (meridian_radius(lat), prime_vertical_radius(lat))
}

/// Normal gravity magnitude (m/s²) at latitude `lat` (rad) and height `h` (m):
/// Somigliana's closed formula on the ellipsoid plus the second-order free-air
/// correction for height (NIMA TR8350.2, eq. 4-3).
pub fn normal_gravity(lat: f64, h: f64) -> f64 {
    let s2 = lat.sin().powi(2);
    let g0 = GAMMA_EQUATOR * (1.0 + SOMIGLIANA_K * s2) / (1.0 - WGS84_E2 * s2).sqrt();
    let m = EARTH_RATE * EARTH_RATE * WGS84_A * WGS84_A * WGS84_B / WGS84_GM;
    g0 * (1.0 - 2.0 / WGS84_A * (1.0 + WGS84_F + m - 2.0 * WGS84_F * s2) * h
        + 3.0 / (WGS84_A * WGS84_A) * h * h)
}

/// Geodetic to ECEF (m).
pub fn geodetic_to_ecef(p: &Geodetic) -> [f64; 3] {
    let (sl, cl) = p.lat.sin_cos();
    let (so, co) = p.lon.sin_cos();
    let n = prime_vertical_radius(p.lat);
    [
        (n + p.height) * cl * co,
        (n + p.height) * cl * so,
        (n * (1.0 - WGS84_E2) + p.height) * sl,
    ]
}

/// ECEF (m) to geodetic, by Bowring's method refined by Newton iterations
/// (sub-millimetre everywhere above the Earth's centre region).
pub fn ecef_to_geodetic(x: [f64; 3]) -> Geodetic {
    let [x, y, z] = x;
    let lon = y.atan2(x);
    let p = x.hypot(y);
    if p < 1e-9 {
        // On the polar axis.
        let lat = if z >= 0.0 {
            std::f64::consts::FRAC_PI_2
        } else {
            -std::f64::consts::FRAC_PI_2
        };
        return Geodetic {
            lat,
            lon: 0.0,
            height: z.abs() - WGS84_B,
        };
    }
    let ep2 = WGS84_E2 / (1.0 - WGS84_E2);
    let theta = (z * WGS84_A).atan2(p * WGS84_B);
    let (st, ct) = theta.sin_cos();
    let mut lat = (z + ep2 * WGS84_B * st.powi(3)).atan2(p - WGS84_E2 * WGS84_A * ct.powi(3));
    let mut h = 0.0;
    for _ in 0..3 {
        let n = prime_vertical_radius(lat);
        let (sl, cl) = lat.sin_cos();
        h = if cl.abs() > 1e-6 {
            p / cl - n
        } else {
            z / sl - n * (1.0 - WGS84_E2)
        };
        lat = z.atan2(p * (1.0 - WGS84_E2 * n / (n + h)));
    }
    Geodetic {
        lat,
        lon,
        height: h,
    }
}

/// A local East-North-Up tangent frame at an origin on the ellipsoid.
#[derive(Debug, Clone, Copy)]
pub struct EnuFrame {
    origin: Geodetic,
    origin_ecef: [f64; 3],
    /// Rows: east, north, up unit vectors in ECEF.
    rot: [[f64; 3]; 3],
}

impl EnuFrame {
    /// A frame with its origin at `origin`.
    pub fn new(origin: Geodetic) -> Self {
        let (sl, cl) = origin.lat.sin_cos();
        let (so, co) = origin.lon.sin_cos();
        Self {
            origin,
            origin_ecef: geodetic_to_ecef(&origin),
            rot: [
                [-so, co, 0.0],
                [-sl * co, -sl * so, cl],
                [cl * co, cl * so, sl],
            ],
        }
    }

    /// The frame's origin.
    pub fn origin(&self) -> Geodetic {
        self.origin
    }

    /// Geodetic position to ENU coordinates (m).
    pub fn to_enu(&self, p: &Geodetic) -> [f64; 3] {
        let e = geodetic_to_ecef(p);
        let d = [
            e[0] - self.origin_ecef[0],
            e[1] - self.origin_ecef[1],
            e[2] - self.origin_ecef[2],
        ];
        let r = &self.rot;
        [
            r[0][0] * d[0] + r[0][1] * d[1] + r[0][2] * d[2],
            r[1][0] * d[0] + r[1][1] * d[1] + r[1][2] * d[2],
            r[2][0] * d[0] + r[2][1] * d[1] + r[2][2] * d[2],
        ]
    }

    /// ENU coordinates (m) back to a geodetic position.
    pub fn to_geodetic(&self, enu: [f64; 3]) -> Geodetic {
        let r = &self.rot;
        let d = [
            r[0][0] * enu[0] + r[1][0] * enu[1] + r[2][0] * enu[2],
            r[0][1] * enu[0] + r[1][1] * enu[1] + r[2][1] * enu[2],
            r[0][2] * enu[0] + r[1][2] * enu[1] + r[2][2] * enu[2],
        ];
        ecef_to_geodetic([
            self.origin_ecef[0] + d[0],
            self.origin_ecef[1] + d[1],
            self.origin_ecef[2] + d[2],
        ])
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn radii_at_equator_and_pole() {
        // Closed forms: R_M(0) = a(1-e²), R_N(0) = a, R_M(90°) = R_N(90°) = a/sqrt(1-e²).
        assert!((meridian_radius(0.0) - WGS84_A * (1.0 - WGS84_E2)).abs() < 1e-6);
        assert!((prime_vertical_radius(0.0) - WGS84_A).abs() < 1e-6);
        let polar = WGS84_A / (1.0 - WGS84_E2).sqrt();
        let half_pi = std::f64::consts::FRAC_PI_2;
        assert!((meridian_radius(half_pi) - polar).abs() < 1e-6);
        assert!((prime_vertical_radius(half_pi) - polar).abs() < 1e-6);
    }

    #[test]
    fn gravity_matches_published_values() {
        // Somigliana at the equator and pole is γ_e and γ_p by construction (1e-9 m/s²
        // is rounding); the free-air gradient near the surface is about -3.086e-6 s⁻²
        // (textbook value), checked to 1 %.
        assert!((normal_gravity(0.0, 0.0) - GAMMA_EQUATOR).abs() < 1e-9);
        assert!((normal_gravity(std::f64::consts::FRAC_PI_2, 0.0) - GAMMA_POLE).abs() < 1e-8);
        let lat = 45f64.to_radians();
        let grad = (normal_gravity(lat, 100.0) - normal_gravity(lat, 0.0)) / 100.0;
        assert!((grad + 3.086e-6).abs() < 0.031e-6, "gradient {grad}");
    }

    proptest! {
        #[test]
        fn ecef_round_trip(lat in -89.9f64..89.9, lon in -180f64..180.0, h in -500f64..10_000.0) {
            let p = Geodetic::from_degrees(lat, lon, h);
            let q = ecef_to_geodetic(geodetic_to_ecef(&p));
            // 1e-10 rad is 0.6 mm on the ground; 1 mm in height.
            prop_assert!((p.lat - q.lat).abs() < 1e-10);
            prop_assert!((p.lon - q.lon).abs() < 1e-10);
            prop_assert!((p.height - q.height).abs() < 1e-3);
        }

        #[test]
        fn enu_round_trip(lat0 in -80f64..80.0, lon0 in -180f64..180.0,
                          e in -50_000f64..50_000.0, n in -50_000f64..50_000.0, u in -100f64..1000.0) {
            let frame = EnuFrame::new(Geodetic::from_degrees(lat0, lon0, 0.0));
            let g = frame.to_geodetic([e, n, u]);
            let back = frame.to_enu(&g);
            // Sub-millimetre round trip over a 100 km square.
            prop_assert!((back[0] - e).abs() < 1e-3);
            prop_assert!((back[1] - n).abs() < 1e-3);
            prop_assert!((back[2] - u).abs() < 1e-3);
        }
    }
}
