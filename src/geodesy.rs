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

/// Earth rate expressed in the local ENU navigation frame at latitude `lat`
/// (rad): ω_ie^n = [0, ω cos L, ω sin L] (rad/s).
pub fn earth_rate_n(lat: f64) -> [f64; 3] {
    let (sl, cl) = lat.sin_cos();
    [0.0, EARTH_RATE * cl, EARTH_RATE * sl]
}

/// Transport rate ω_en^n (rad/s): the turning of the ENU frame as it is carried
/// over the curved Earth by the ENU velocity `v` (m/s) at latitude `lat` (rad) and
/// height `h` (m): [−v_N/(R_M+h), v_E/(R_N+h), v_E tan L/(R_N+h)].
pub fn transport_rate(lat: f64, h: f64, v: [f64; 3]) -> [f64; 3] {
    let (rm, rn) = radii(lat);
    [
        -v[1] / (rm + h),
        v[0] / (rn + h),
        v[0] * lat.tan() / (rn + h),
    ]
}

/// Normal gravity vector in ENU (m/s²): [0, 0, −γ(L, h)].
pub fn gravity_n(lat: f64, h: f64) -> [f64; 3] {
    [0.0, 0.0, -normal_gravity(lat, h)]
}

/// Position rates (dL/dt, dλ/dt, dh/dt) from an ENU velocity (m/s) at
/// latitude `lat` (rad) and height `h` (m).
pub fn position_rate(lat: f64, h: f64, v: [f64; 3]) -> [f64; 3] {
    let (rm, rn) = radii(lat);
    [v[1] / (rm + h), v[0] / ((rn + h) * lat.cos()), v[2]]
}

/// The Earth-related quantities a strapdown navigator needs at one position and
/// velocity (the "eth" of PSINS): trigonometry of latitude, radii, Earth rate,
/// transport rate, gravity and the gravity-minus-Coriolis term.
#[derive(Debug, Clone, Copy, Default)]
pub struct EarthState {
    /// sin L.
    pub sin_lat: f64,
    /// cos L.
    pub cos_lat: f64,
    /// tan L.
    pub tan_lat: f64,
    /// R_M + h (m).
    pub rm_h: f64,
    /// R_N + h (m).
    pub rn_h: f64,
    /// (R_N + h) cos L (m).
    pub clrn_h: f64,
    /// Earth rate ω_ie^n (rad/s).
    pub w_ie: [f64; 3],
    /// Transport rate ω_en^n (rad/s).
    pub w_en: [f64; 3],
    /// ω_in^n = ω_ie^n + ω_en^n (rad/s).
    pub w_in: [f64; 3],
    /// Gravity vector g^n (m/s²).
    pub g: [f64; 3],
    /// g^n − (2 ω_ie^n + ω_en^n) × v^n (m/s²): gravity less Coriolis.
    pub g_cc: [f64; 3],
}

impl EarthState {
    /// The quantities at latitude `lat` (rad), height `h` (m) and ENU velocity `v` (m/s).
    #[inline]
    pub fn new(lat: f64, h: f64, v: [f64; 3]) -> Self {
        let (sl, cl) = lat.sin_cos();
        let s2 = sl * sl;
        let w2 = 1.0 - WGS84_E2 * s2;
        let sqw = w2.sqrt();
        let rn = WGS84_A / sqw;
        let rm = rn * (1.0 - WGS84_E2) / w2;
        let rm_h = rm + h;
        let rn_h = rn + h;
        let tl = sl / cl;
        let w_ie = [0.0, EARTH_RATE * cl, EARTH_RATE * sl];
        let w_en = [-v[1] / rm_h, v[0] / rn_h, v[0] * tl / rn_h];
        let w_in = [w_ie[0] + w_en[0], w_ie[1] + w_en[1], w_ie[2] + w_en[2]];
        let g0 = GAMMA_EQUATOR * (1.0 + SOMIGLIANA_K * s2) / sqw;
        let m = EARTH_RATE * EARTH_RATE * WGS84_A * WGS84_A * WGS84_B / WGS84_GM;
        let gm = g0
            * (1.0 - 2.0 / WGS84_A * (1.0 + WGS84_F + m - 2.0 * WGS84_F * s2) * h
                + 3.0 / (WGS84_A * WGS84_A) * h * h);
        let g = [0.0, 0.0, -gm];
        // (2 ω_ie + ω_en) × v
        let a = [w_ie[0] + w_in[0], w_ie[1] + w_in[1], w_ie[2] + w_in[2]];
        let c = [
            a[1] * v[2] - a[2] * v[1],
            a[2] * v[0] - a[0] * v[2],
            a[0] * v[1] - a[1] * v[0],
        ];
        Self {
            sin_lat: sl,
            cos_lat: cl,
            tan_lat: tl,
            rm_h,
            rn_h,
            clrn_h: cl * rn_h,
            w_ie,
            w_en,
            w_in,
            g,
            g_cc: [g[0] - c[0], g[1] - c[1], g[2] - c[2]],
        }
    }

    /// Position rates (dL/dt, dλ/dt, dh/dt) for ENU velocity `v` at this state.
    #[inline]
    pub fn position_rate(&self, v: [f64; 3]) -> [f64; 3] {
        [v[1] / self.rm_h, v[0] / self.clrn_h, v[2]]
    }
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

    #[test]
    fn earth_state_agrees_with_the_separate_functions() {
        let lat = 30f64.to_radians();
        let v = [10.0, -5.0, 0.3];
        let e = EarthState::new(lat, 120.0, v);
        let wen = transport_rate(lat, 120.0, v);
        let wie = earth_rate_n(lat);
        for i in 0..3 {
            assert!((e.w_en[i] - wen[i]).abs() < 1e-18);
            assert!((e.w_ie[i] - wie[i]).abs() < 1e-18);
        }
        assert!((e.g[2] - gravity_n(lat, 120.0)[2]).abs() < 1e-12);
        let pr = position_rate(lat, 120.0, v);
        let pr2 = e.position_rate(v);
        for i in 0..3 {
            assert!((pr[i] - pr2[i]).abs() < 1e-18);
        }
        // Transport rate of a vehicle driving east at 10 m/s at 30°: v/(R_N+h) about the
        // north axis, 1.57e-6 rad/s (hand computation with R_N ≈ 6.3836e6 m).
        assert!((e.w_en[1] + 0.0 - 10.0 / (prime_vertical_radius(lat) + 120.0)).abs() < 1e-15);
        assert!((e.w_en[1] - 1.5665e-6).abs() < 1e-9);
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
