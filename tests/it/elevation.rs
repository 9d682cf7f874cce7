//! `[map] elevation`: GeoTIFF elevation models written by the tests with the
//! `tiff` crate's encoder (a plane tilted 5 % over the bundled Helsinki
//! map), read back, driven by the truth trajectory, carried into the tag
//! files, tunnels interpolated between their portals, and bad input refused
//! through the binary.

use crate::common;

use common::{repo, run};

use std::path::{Path, PathBuf};
use tiff::encoder::{colortype, TiffEncoder};
use tiff::tags::Tag;
use waymark::elevation::{HeightProfile, MAX_DEM_PIXELS};
use waymark::{Dem, Network, Scenario, TruthSource};

/// Centre of the plane's tilt (the Helsinki map's middle).
const LAT_C: f64 = 60.1716;
const LON_C: f64 = 24.944;
/// Metres per degree of latitude and of longitude at `LAT_C` (spherical,
/// R = 6371 km: the plane only has to be a plane in latitude/longitude,
/// which bilinear interpolation reproduces exactly).
const M_PER_DEG_LAT: f64 = 6_371_000.0 * std::f64::consts::PI / 180.0;
fn m_per_deg_lon() -> f64 {
    M_PER_DEG_LAT * LAT_C.to_radians().cos()
}
/// Grades east and north: 3 % and 4 %, 5 % up the steepest direction.
const GRADE_E: f64 = 0.03;
const GRADE_N: f64 = 0.04;

/// The tilted plane: 50 m at the centre.
fn plane(lat: f64, lon: f64) -> f64 {
    50.0 + GRADE_E * (lon - LON_C) * m_per_deg_lon() + GRADE_N * (lat - LAT_C) * M_PER_DEG_LAT
}

#[derive(Clone, Copy)]
enum Georef {
    /// ModelTiepoint + ModelPixelScale, PixelIsArea.
    Area,
    /// ModelTiepoint + ModelPixelScale, PixelIsPoint.
    Point,
    /// ModelTransformation, PixelIsArea.
    Transform,
}

#[derive(Clone, Copy)]
struct Spec {
    south: f64,
    north: f64,
    west: f64,
    east: f64,
    width: u32,
    height: u32,
    georef: Georef,
    /// GeoKeys: (model type, CRS key, CRS code).
    crs: (u16, u16, u16),
    int16: bool,
    nodata: Option<&'static str>,
}

/// A DEM over the Helsinki map (60.1642..60.1791 N, 24.9352..24.9534 E)
/// with 0.00025° pixels.
fn helsinki() -> Spec {
    Spec {
        south: 60.160,
        north: 60.185,
        west: 24.930,
        east: 24.960,
        width: 120,
        height: 100,
        georef: Georef::Area,
        crs: (2, 2048, 4326),
        int16: false,
        nodata: None,
    }
}

/// Writes a single-band GeoTIFF whose pixel centres hold `h(lat, lon)`.
fn write_dem(path: &Path, s: Spec, h: impl Fn(f64, f64) -> f64) {
    let point = matches!(s.georef, Georef::Point);
    let (dx, dy) = if point {
        (
            (s.east - s.west) / f64::from(s.width - 1),
            (s.north - s.south) / f64::from(s.height - 1),
        )
    } else {
        (
            (s.east - s.west) / f64::from(s.width),
            (s.north - s.south) / f64::from(s.height),
        )
    };
    let off = if point { 0.0 } else { 0.5 };
    let mut values = Vec::with_capacity((s.width * s.height) as usize);
    for r in 0..s.height {
        for c in 0..s.width {
            let lat = s.north - (f64::from(r) + off) * dy;
            let lon = s.west + (f64::from(c) + off) * dx;
            values.push(h(lat, lon));
        }
    }
    let file = std::fs::File::create(path).unwrap();
    let mut enc = TiffEncoder::new(file).unwrap();
    let keys: Vec<u16> = vec![
        1,
        1,
        0,
        3,
        1024,
        0,
        1,
        s.crs.0,
        1025,
        0,
        1,
        if point { 2 } else { 1 },
        s.crs.1,
        0,
        1,
        s.crs.2,
    ];
    macro_rules! tags {
        ($img:expr) => {{
            let d = $img.encoder();
            d.write_tag(Tag::GeoKeyDirectoryTag, &keys[..]).unwrap();
            match s.georef {
                Georef::Area | Georef::Point => {
                    d.write_tag(Tag::ModelPixelScaleTag, &[dx, dy, 0.0][..])
                        .unwrap();
                    d.write_tag(
                        Tag::ModelTiepointTag,
                        &[0.0, 0.0, 0.0, s.west, s.north, 0.0][..],
                    )
                    .unwrap();
                }
                Georef::Transform => {
                    let m = [
                        dx, 0.0, 0.0, s.west, 0.0, -dy, 0.0, s.north, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
                        0.0, 1.0,
                    ];
                    d.write_tag(Tag::ModelTransformationTag, &m[..]).unwrap();
                }
            }
            if let Some(n) = s.nodata {
                d.write_tag(Tag::GdalNodata, n).unwrap();
            }
        }};
    }
    if s.int16 {
        let mut img = enc
            .new_image::<colortype::GrayI16>(s.width, s.height)
            .unwrap();
        tags!(img);
        let v: Vec<i16> = values.iter().map(|x| x.round() as i16).collect();
        img.write_data(&v).unwrap();
    } else {
        let mut img = enc
            .new_image::<colortype::Gray32Float>(s.width, s.height)
            .unwrap();
        tags!(img);
        let v: Vec<f32> = values.iter().map(|&x| x as f32).collect();
        img.write_data(&v).unwrap();
    }
}

/// Seeded points inside the map's extent.
fn points(n: usize) -> Vec<(f64, f64)> {
    let mut x: u64 = 0x9e37_79b9_7f4a_7c15;
    let mut next = || {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        (x >> 11) as f64 / (1u64 << 53) as f64
    };
    (0..n)
        .map(|_| (60.1642 + 0.0149 * next(), 24.9352 + 0.0182 * next()))
        .collect()
}

/// Every georeferencing form reads the plane back: a linear function of
/// latitude and longitude, which bilinear interpolation reproduces
/// exactly; the tolerance is the f32 storage (heights ≤ 200 m: a relative
/// 6e-8, 1.2e-5 m) with margin.
#[test]
fn every_georeferencing_reads_the_plane_back() {
    let dir = tempfile::tempdir().unwrap();
    for (name, georef) in [
        ("area", Georef::Area),
        ("point", Georef::Point),
        ("transform", Georef::Transform),
    ] {
        let path = dir.path().join(format!("{name}.tif"));
        write_dem(
            &path,
            Spec {
                georef,
                ..helsinki()
            },
            plane,
        );
        let dem = Dem::open(&[path]).unwrap();
        for (lat, lon) in points(500) {
            let h = dem.height(lat, lon).unwrap();
            assert!(
                (h - plane(lat, lon)).abs() < 1e-3,
                "{name}: {lat} {lon}: {h}"
            );
        }
    }
    // Two tiles side by side (west and east halves), each PixelIsArea:
    // points between the tiles' outermost pixel centres use the clamped
    // neighbourhood, exact along the border for a plane only to half a
    // pixel's height change (0.00025° / 2 ≈ 7 m east at 3 %: 0.21 m).
    let west = dir.path().join("west.tif");
    let east = dir.path().join("east.tif");
    let half = Spec {
        east: 24.945,
        width: 60,
        ..helsinki()
    };
    write_dem(&west, half, plane);
    write_dem(
        &east,
        Spec {
            west: 24.945,
            east: 24.960,
            ..half
        },
        plane,
    );
    let dem = Dem::open(&[west, east]).unwrap();
    for (lat, lon) in points(500) {
        let h = dem.height(lat, lon).unwrap();
        let tol = if (lon - 24.945).abs() < 0.000125 {
            0.25
        } else {
            1e-3
        };
        assert!((h - plane(lat, lon)).abs() < tol, "{lat} {lon}: {h}");
    }
}

/// No data: Int16 with GDAL_NODATA = -32768 in one pixel; points whose
/// bilinear neighbourhood uses it are an error naming the file, the rest
/// read (to the Int16 rounding, 0.5 m).
#[test]
fn no_data_pixels_are_an_error_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("voids.tif");
    let s = Spec {
        int16: true,
        nodata: Some("-32768"),
        ..helsinki()
    };
    // The void: the pixel whose centre is at row 50, column 60.
    let (void_lat, void_lon) = (s.north - 50.5 * 0.00025, s.west + 60.5 * 0.00025);
    write_dem(&path, s, |lat, lon| {
        if (lat - void_lat).abs() < 1e-9 && (lon - void_lon).abs() < 1e-9 {
            -32768.0
        } else {
            plane(lat, lon)
        }
    });
    let dem = Dem::open(std::slice::from_ref(&path)).unwrap();
    let e = dem
        .height(void_lat + 0.0001, void_lon - 0.0001)
        .unwrap_err()
        .to_string();
    assert!(e.contains("voids.tif") && e.contains("no data"), "{e}");
    let h = dem.height(void_lat + 0.002, void_lon + 0.002).unwrap();
    assert!((h - plane(void_lat + 0.002, void_lon + 0.002)).abs() <= 0.5 + 1e-9);
}

/// Smoothing keeps a linear profile and removes pixel noise: ±2 m uniform
/// noise (σ = 4/√12 = 1.155 m) on every 5 m node of a 3 % ramp gives
/// node-to-node grades of σ = 1.155·√2/5 = 33 %. Twice a 17-node box is
/// a triangular kernel w_j = (17 − |j|)/17²; the grade, a central
/// difference over 10 m, weighs the noise by (w_{j−1} − w_{j+1})/10 m, whose
/// squares sum to (32·(2/289)² + 2·(1/289)²)/100 → σ = 1.155 × 0.0395/10 =
/// 0.46 %. The worst of 360 correlated grades stays below 4σ = 1.8 %.
#[test]
fn the_profile_keeps_ramps_and_smooths_noise() {
    let ramp: Vec<f64> = (0..400).map(|i| 10.0 + 0.03 * 5.0 * i as f64).collect();
    let p = HeightProfile::smoothed(5.0, &ramp, 40.0);
    for c in [0.0, 2.5, 100.0, 1234.5, 1995.0] {
        assert!((p.height_at(c) - (10.0 + 0.03 * c)).abs() < 1e-9, "{c}");
        assert!((p.grade_at(c) - 0.03).abs() < 1e-9, "{c}");
    }
    let mut x: u64 = 12345;
    let noisy: Vec<f64> = ramp
        .iter()
        .map(|h| {
            x = x
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            h + 4.0 * ((x >> 11) as f64 / (1u64 << 53) as f64 - 0.5)
        })
        .collect();
    let p = HeightProfile::smoothed(5.0, &noisy, 40.0);
    let worst = (20..380)
        .map(|i| (p.grade_at(i as f64 * 5.0) - 0.03).abs())
        .fold(0.0, f64::max);
    assert!(worst < 0.018, "worst grade error {worst}");
}

/// A scenario file in `dir` on the bundled map with `extra` TOML lines
/// appended after `[map]`'s path.
fn scenario(dir: &Path, map_extra: &str, route: &str) -> PathBuf {
    let text = format!(
        r#"name = "elevation"
requirement_m = 5.0
seed = 3
[map]
path = "{map}"
{map_extra}
[[route]]
{route}
[navigator]
mode = "integrated"
[imu]
rate_hz = 100
gyro_bias_dph = [0.01, 0.01, 0.01]
accel_bias_ug = [25, 25, 25]
gyro_arw_dprh = 0.002
accel_vrw_ugprhz = 5
[odometer]
scale_factor_error = 0.001
noise_mps = 0.02
pulse_m = 0.02
[aiding]
odometer = false
baro = true
rfid = true
[planner]
candidate_spacing_m = 100
validation_runs = 4
"#,
        map = repo("maps/helsinki.osm.pbf").display()
    );
    let p = dir.join("scenario.toml");
    std::fs::write(&p, text).unwrap();
    p
}

const ROUTE: &str = "waypoints = [[60.1660, 24.9380], [60.1770, 24.9510]]\nspeed_kmh = 40";

/// Chainage intervals of the route's tunnels and bridges.
fn structures(net: &Network, route: &waymark::Route) -> Vec<(f64, f64)> {
    route
        .spans
        .iter()
        .filter(|s| {
            let a = &net.roads[s.road as usize].attributes;
            a.tunnel || a.bridge
        })
        .map(|s| (s.start_chainage_m, s.end_chainage_m))
        .collect()
}

/// Total heading change (rad) of the route's polyline within ±`half` m
/// of chainage `c`.
fn turning_near(route: &waymark::Route, c: f64, half: f64) -> f64 {
    let v = &route.vertices;
    let mut total = 0.0;
    for w in v.windows(3) {
        if w[1].chainage_m < c - half || w[1].chainage_m > c + half {
            continue;
        }
        let h = |a: &waymark::route::RouteVertex, b: &waymark::route::RouteVertex| {
            (b.enu[0] - a.enu[0]).atan2(b.enu[1] - a.enu[1])
        };
        let mut d = h(&w[1], &w[2]) - h(&w[0], &w[1]);
        d = (d + std::f64::consts::PI).rem_euclid(2.0 * std::f64::consts::PI)
            - std::f64::consts::PI;
        total += d.abs();
    }
    total
}

/// The truth drives the plane: its height at its own latitude/longitude
/// is the plane's, away from tunnels and bridges, and its pitch is the
/// plane's grade along its heading.
#[test]
fn the_truth_trajectory_follows_the_terrain() {
    let dir = tempfile::tempdir().unwrap();
    write_dem(&dir.path().join("dem.tif"), helsinki(), plane);
    let scn = Scenario::load(&scenario(dir.path(), "elevation = \"dem.tif\"", ROUTE)).unwrap();
    let truth = TruthSource::new(&scn).unwrap();
    let net = truth.network().unwrap();
    let route = truth.route().unwrap();
    let structures = structures(net, route);
    let (mut lo, mut hi) = (f64::MAX, f64::MIN);
    // Worst height and pitch errors on straight stretches and anywhere.
    let (mut straight, mut anywhere) = ([0.0f64; 2], [0.0f64; 2]);
    let mut n_straight = 0;
    for a in truth.samples().step_by(10) {
        let s = a.state;
        let (lat, lon) = (s.lat.to_degrees(), s.lon.to_degrees());
        lo = lo.min(s.h);
        hi = hi.max(s.h);
        let c = truth.chainage_at(a.distance_m).unwrap();
        // Smoothing reaches ±80 m: farther from every structure than that
        // (with a 20 m margin) the terrain alone sets the height.
        if structures
            .iter()
            .any(|&(a, b)| c > a - 100.0 && c < b + 100.0)
        {
            continue;
        }
        let dh = (s.h - plane(lat, lon)).abs();
        let speed = s.v[0].hypot(s.v[1]);
        let dp = if speed > 1.0 {
            // The plane's rise per metre along the direction of travel.
            let along = (GRADE_E * s.v[0] + GRADE_N * s.v[1]) / speed;
            let (pitch, _, _) = waymark::attitude::QuatExt::to_euler(&s.q);
            (pitch - along.atan()).abs()
        } else {
            0.0
        };
        anywhere = [anywhere[0].max(dh), anywhere[1].max(dp)];
        if turning_near(route, c, 90.0) < 5f64.to_radians() {
            n_straight += 1;
            straight = [straight[0].max(dh), straight[1].max(dp)];
        }
    }
    eprintln!(
        "heights {lo:.2}..{hi:.2} m; straight ({n_straight} samples): {:.3} m, {:.4} rad; \
         anywhere: {:.3} m, {:.4} rad",
        straight[0], straight[1], anywhere[0], anywhere[1]
    );
    // The route climbs the plane: a real test of following it.
    assert!(hi - lo > 30.0, "{lo}..{hi}");
    assert!(
        n_straight > 50,
        "{n_straight} samples on straight stretches"
    );
    // Straight (< 5° of turning within the ±80 m smoothing reach): the
    // smoothed heights are the plane's along the centre line; the truth
    // drives its lane, ≤ ~5 m beside it (5 % × 5 m = 0.25 m). Pitch: the
    // grade seen across 5° of turning changes by ≤ 5 % × sin 5° = 0.4 %.
    assert!(
        straight[0] < 0.3,
        "straight: height error {} m",
        straight[0]
    );
    assert!(
        straight[1] < 0.005,
        "straight: pitch error {} rad",
        straight[1]
    );
    // At a bend the road's height is not linear in chainage: turning by θ
    // kinks the grade by up to Δg = 2 × 5 % × sin(θ/2) (10 % for a U-turn),
    // and the triangular ±80 m kernel rounds the kink by Δg/2 × E|x| =
    // Δg/2 × 80/3 m (1.33 m at 10 %), the plan's ±20 m one along its path
    // by Δg/2 × 20/3 m (0.33 m), and the grade by up to Δg/2 (5 %).
    assert!(
        anywhere[0] < 1.33 + 0.33 + 0.25,
        "height error {} m",
        anywhere[0]
    );
    assert!(anywhere[1] < 0.05, "pitch error {} rad", anywhere[1]);
}

/// A tunnel's heights are linear in chainage between its portals, not the
/// hill above it: a 60 m hill (σ 12 m) is put over the middle of the
/// longest tunnel run found on seeded routes across the map. The raw
/// profile (no smoothing) is, all through the tunnel, the straight line
/// between the portals' terrain heights (to the f32 storage, 1e-3 m); the
/// smoothed profile stays far below the hilltop.
#[test]
fn tunnels_are_interpolated_between_their_portals() {
    let net = Network::load(&repo("maps/helsinki.osm.pbf"), &Default::default()).unwrap();
    // The route with the longest tunnel or bridge run at least 100 m inside it.
    let pts = points(80);
    let mut best: Option<(waymark::Route, f64, f64)> = None;
    for w in pts.chunks(2) {
        let Ok(route) = waymark::plan_route(&net, &[[w[0].0, w[0].1], [w[1].0, w[1].1]]) else {
            continue;
        };
        let mut runs: Vec<(f64, f64)> = Vec::new();
        for (a, b) in structures(&net, &route) {
            match runs.last_mut() {
                Some(r) if (r.1 - a).abs() < 1e-6 => r.1 = b,
                _ => runs.push((a, b)),
            }
        }
        for (a, b) in runs {
            let inside = a > 100.0 && b < route.length_m - 100.0;
            if inside && best.as_ref().is_none_or(|x| b - a > x.2 - x.1) {
                best = Some((route.clone(), a, b));
            }
        }
    }
    let (route, ca, cb) = best.expect("a route through a tunnel");
    eprintln!("tunnel run {ca:.1}..{cb:.1} m of {:.1} m", route.length_m);
    assert!(cb - ca > 40.0, "the longest tunnel run is {:.1} m", cb - ca);
    let lat_lon = |c: f64| {
        let p = route.position_at(c);
        let g = net.frame.to_geodetic([p[0], p[1], 0.0]);
        (g.lat_deg(), g.lon_deg())
    };
    let (mid_lat, mid_lon) = lat_lon(0.5 * (ca + cb));
    let terrain = move |lat: f64, lon: f64| {
        let e = (lon - mid_lon) * m_per_deg_lon();
        let n = (lat - mid_lat) * M_PER_DEG_LAT;
        plane(lat, lon) + 60.0 * (-(e * e + n * n) / (2.0 * 12.0 * 12.0)).exp()
    };
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("hill.tif");
    // 0.00005° pixels (2.8 × 5.6 m) resolve the hill.
    let fine = Spec {
        width: 600,
        height: 500,
        ..helsinki()
    };
    write_dem(&path, fine, terrain);
    let dem = Dem::open(&[path]).unwrap();
    let at = |c: f64| {
        let (la, lo) = lat_lon(c);
        dem.height(la, lo).unwrap()
    };
    let raw = waymark::trajectory::route_heights_with(&net, &route, &dem, 0.0).unwrap();
    let (ha, hb) = (at(ca), at(cb));
    let line = |c: f64| ha + (hb - ha) * (c - ca) / (cb - ca);
    let mut above = 0.0f64;
    for i in 0..=40 {
        let c = ca + (cb - ca) * f64::from(i) / 40.0;
        let h = raw.height_at(c);
        // Nodes every ≤ 5 m: the raw profile is linear between nodes, and
        // the nodes next to the portals lie outside the tunnel (terrain):
        // within 5 m of a portal the line is only approached.
        if c > ca + 5.0 && c < cb - 5.0 {
            assert!((h - line(c)).abs() < 1e-3, "{c}: {h} against {}", line(c));
        }
        above = above.max(at(c) - h);
    }
    // The hill is over the tunnel: following the terrain would differ.
    assert!(
        above > 30.0,
        "the terrain is only {above} m above the tunnel"
    );
    let smoothed = waymark::trajectory::route_heights(&net, &route, &dem).unwrap();
    let mid = 0.5 * (ca + cb);
    assert!(at(mid) - smoothed.height_at(mid) > 30.0);
}

/// Plans the test scenario in `dir` into `dir/out` and returns tags.csv's
/// (lat, lon, height) rows and tags.meta.json.
fn plan(dir: &Path, map_extra: &str) -> (Vec<(f64, f64, f64)>, serde_json::Value) {
    let scn = scenario(dir, map_extra, ROUTE);
    let out = run(&["plan", scn.to_str().unwrap(), "--out", "out", "-q"], dir);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let mut rdr = csv::Reader::from_path(dir.join("out/tags.csv")).unwrap();
    let h = rdr.headers().unwrap().clone();
    let col = |n: &str| h.iter().position(|x| x == n).unwrap();
    let (la, lo, he) = (col("lat"), col("lon"), col("height_m"));
    let rows = rdr
        .records()
        .map(|r| {
            let r = r.unwrap();
            let f = |i: usize| r[i].parse::<f64>().unwrap();
            (f(la), f(lo), f(he))
        })
        .collect();
    let meta = std::fs::read_to_string(dir.join("out/tags.meta.json")).unwrap();
    (rows, serde_json::from_str(&meta).unwrap())
}

/// With a DEM the tag files carry the terrain's heights: tags.csv's
/// heights are the plane's at the tags' positions, KML places them at
/// absolute altitudes, GPX has `<ele>`, the metadata and the report say
/// where the heights come from. Without one they are 0 m and every file
/// says so.
#[test]
fn plans_carry_terrain_heights_into_every_file() {
    let dir = tempfile::tempdir().unwrap();
    write_dem(&dir.path().join("dem.tif"), helsinki(), plane);
    let (tags, meta) = plan(dir.path(), "elevation = \"dem.tif\"");
    assert!(tags.len() >= 3, "{} tags", tags.len());
    let mut errors: Vec<f64> = tags
        .iter()
        .map(|&(lat, lon, h)| (h - plane(lat, lon)).abs())
        .collect();
    errors.sort_by(f64::total_cmp);
    eprintln!("tag height errors {errors:?}");
    // A tag's height is the truth's where it passes the tag: the bounds of
    // the truth's test (1.91 m at the sharpest bend), plus a roadside
    // tag's offset from the lane (≤ 5 m, 0.25 m at 5 %); the heights also
    // vary (the plane spans 76 m over the route), so 0 would fail.
    assert!(errors[errors.len() - 1] < 2.2, "{errors:?}");
    assert!(errors[errors.len() / 2] < 0.5, "median {errors:?}");
    let spread = tags.iter().map(|t| t.2).fold(f64::MIN, f64::max)
        - tags.iter().map(|t| t.2).fold(f64::MAX, f64::min);
    assert!(spread > 10.0, "tag heights span {spread} m");
    assert_eq!(meta["heights_known"], true);
    let why = meta["parameters"]["height_m"].as_str().unwrap();
    assert!(why.contains("dem.tif") && why.contains("terrain"), "{why}");
    let out = dir.path().join("out");
    let kml: kml::Kml = std::fs::read_to_string(out.join("tags.kml"))
        .unwrap()
        .parse()
        .unwrap();
    let kml_text = kml.to_string();
    assert_eq!(
        kml_text
            .matches("<altitudeMode>absolute</altitudeMode>")
            .count(),
        tags.len()
    );
    let gpx = gpx::read(std::fs::File::open(out.join("tags.gpx")).unwrap()).unwrap();
    assert_eq!(gpx.waypoints.len(), tags.len());
    for (w, t) in gpx.waypoints.iter().zip(&tags) {
        assert!(
            (w.elevation.unwrap() - t.2).abs() < 0.006,
            "{:?} {t:?}",
            w.elevation
        );
    }
    let plan_json = std::fs::read_to_string(out.join("plan.json")).unwrap();
    assert!(plan_json.contains("dem.tif"));
    // plan.json's tag_files says what tags.meta.json says of the heights.
    let pj: serde_json::Value = serde_json::from_str(&plan_json).unwrap();
    assert_eq!(pj["tag_files"]["heights_source"], "elevation_model");
    assert_eq!(pj["tag_files"]["heights_known"], true);
    let rep = run(&["report", "out"], dir.path());
    assert!(
        rep.status.success(),
        "{}",
        String::from_utf8_lossy(&rep.stderr)
    );
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    assert!(html.contains("Heights: the terrain"), "report");

    // Without an elevation model.
    let dir = tempfile::tempdir().unwrap();
    let (tags, meta) = plan(dir.path(), "");
    assert!(tags.iter().all(|t| t.2 == 0.0));
    assert_eq!(meta["heights_known"], false);
    let why = meta["parameters"]["height_m"].as_str().unwrap();
    assert!(why.starts_with("none (no [map] elevation)"), "{why}");
    let kml = std::fs::read_to_string(dir.path().join("out/tags.kml")).unwrap();
    assert!(!kml.contains("absolute"));
    let gpx = std::fs::read_to_string(dir.path().join("out/tags.gpx")).unwrap();
    assert!(!gpx.contains("<ele>"));
    let rep = run(&["report", "out"], dir.path());
    assert!(rep.status.success());
    let html = std::fs::read_to_string(dir.path().join("out/report.html")).unwrap();
    assert!(html.contains("Heights: none (no [map] elevation)"));
}

/// A TIFF whose header declares `w` × `h` Int16 pixels and holds none.
fn huge_header(w: u32, h: u32) -> Vec<u8> {
    let mut b: Vec<u8> = b"II*\0".to_vec();
    b.extend_from_slice(&8u32.to_le_bytes());
    // (tag, type, count, value): SHORT = 3, LONG = 4.
    let entries: [(u16, u16, u32, u32); 10] = [
        (256, 4, 1, w),
        (257, 4, 1, h),
        (258, 3, 1, 16),
        (259, 3, 1, 1),
        (262, 3, 1, 1),
        (273, 4, 1, 200),
        (277, 3, 1, 1),
        (278, 4, 1, h),
        (279, 4, 1, u32::MAX),
        (339, 3, 1, 2),
    ];
    b.extend_from_slice(&(entries.len() as u16).to_le_bytes());
    for (tag, ty, count, value) in entries {
        b.extend_from_slice(&tag.to_le_bytes());
        b.extend_from_slice(&ty.to_le_bytes());
        b.extend_from_slice(&count.to_le_bytes());
        if ty == 3 {
            b.extend_from_slice(&(value as u16).to_le_bytes());
            b.extend_from_slice(&[0, 0]);
        } else {
            b.extend_from_slice(&value.to_le_bytes());
        }
    }
    b.extend_from_slice(&0u32.to_le_bytes());
    b
}

/// Bad elevation input through the binary: one error line naming the
/// file and what is wrong, exit code 1, for `simulate` and `plan`.
#[test]
fn bad_elevation_models_are_one_line_errors() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("text.tif"), "this is not a TIFF\n").unwrap();
    write_dem(
        &d.join("utm.tif"),
        Spec {
            crs: (1, 3072, 32635),
            ..helsinki()
        },
        plane,
    );
    write_dem(
        &d.join("nad27.tif"),
        Spec {
            crs: (2, 2048, 4267),
            ..helsinki()
        },
        plane,
    );
    // Covers only the route's southern end.
    write_dem(
        &d.join("south.tif"),
        Spec {
            north: 60.168,
            height: 32,
            ..helsinki()
        },
        plane,
    );
    std::fs::write(d.join("huge.tif"), huge_header(1_000_000, 1_000_000)).unwrap();
    write_dem(&d.join("dem.tif"), helsinki(), plane);
    let cases: [(&str, &str, &[&str]); 7] = [
        (
            "elevation = \"missing.tif\"",
            "missing.tif",
            &["No such file"],
        ),
        (
            "elevation = \"text.tif\"",
            "text.tif",
            &["not a readable TIFF"],
        ),
        (
            "elevation = \"utm.tif\"",
            "utm.tif",
            &["projected CRS", "EPSG:32635", "EPSG:4326"],
        ),
        (
            "elevation = \"nad27.tif\"",
            "nad27.tif",
            &["EPSG:4267", "not WGS 84"],
        ),
        (
            "elevation = [\"south.tif\"]",
            "south.tif",
            &["does not cover"],
        ),
        (
            "elevation = \"huge.tif\"",
            "huge.tif",
            &["1000000 × 1000000 pixels", "limit"],
        ),
        (
            "elevation = []",
            "scenario.toml",
            &["map.elevation is an empty list"],
        ),
    ];
    for (extra, file, words) in cases {
        for cmd in ["simulate", "plan"] {
            let scn = scenario(d, extra, ROUTE);
            let out = run(&[cmd, scn.to_str().unwrap(), "--out", "out", "-q"], d);
            let err = String::from_utf8_lossy(&out.stderr);
            assert_eq!(out.status.code(), Some(1), "{cmd} {extra}: {err}");
            assert_eq!(err.trim_end().lines().count(), 1, "{cmd} {extra}: {err}");
            assert!(err.contains(file), "{cmd} {extra}: {err}");
            for w in words {
                assert!(err.contains(w), "{cmd} {extra}: {w} not in {err}");
            }
        }
    }
    // A constant route height and an elevation model contradict.
    let scn = scenario(
        d,
        "elevation = \"dem.tif\"",
        &format!("{ROUTE}\nheight_m = 12"),
    );
    let out = run(
        &["simulate", scn.to_str().unwrap(), "--out", "out", "-q"],
        d,
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(
        err.contains("route[0].height_m") && err.contains("map.elevation"),
        "{err}"
    );
    // The pixel limit is the one documented.
    assert_eq!(MAX_DEM_PIXELS, 1 << 27);
}

#[test]
fn heights_no_terrain_has_are_refused_naming_the_file() {
    // Heights of 3e38 m (a float raster's damaged or unmarked no-data
    // pixels) made the navigator diverge, blamed on the [imu] and [filter]
    // settings; 1e6 m and -20 km simulated a drive 1000 km up or 20 km
    // down without a word.
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for (name, h, shown) in [
        ("float-max.tif", 3e38, "e38 m"),
        ("space.tif", 1e6, "1000000 m"),
        ("deep.tif", -20_000.0, "-20000 m"),
        ("neg.tif", -3e38, "e38 m"),
    ] {
        write_dem(&d.join(name), helsinki(), |_, _| h);
        let scn = scenario(d, &format!("elevation = \"{name}\""), ROUTE);
        for cmd in ["simulate", "plan"] {
            let out = run(&[cmd, scn.to_str().unwrap(), "--out", "out", "-q"], d);
            let err = String::from_utf8_lossy(&out.stderr);
            assert_eq!(out.status.code(), Some(1), "{cmd} {name}: {err}");
            assert_eq!(err.trim_end().lines().count(), 1, "{cmd} {name}: {err}");
            for w in [
                name,
                shown,
                "outside -1000 to 10000 m",
                "not a terrain height",
            ] {
                assert!(err.contains(w), "{cmd} {name}: {w:?} not in {err}");
            }
            assert!(!d.join("out").exists(), "{cmd} {name}: an output folder");
        }
    }
    // The range's ends are terrain (a plane at the limits still runs).
    write_dem(&d.join("high.tif"), helsinki(), |_, _| 9_000.0);
    let scn = scenario(d, "elevation = \"high.tif\"", ROUTE);
    let out = run(
        &["simulate", scn.to_str().unwrap(), "--out", "out", "-q"],
        d,
    );
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// The portal heights (the DEM's) of the tunnel-or-bridge structure each
/// structure road belongs to: structures are the connected sets of
/// structure sections; portals their nodes that end the network or touch
/// an ordinary road. Returns road id → (lowest, highest) portal height.
fn structure_portal_ranges(
    net: &Network,
    dem: &Dem,
) -> std::collections::HashMap<String, (f64, f64)> {
    let m = &net.model;
    let structure = |s: u32| {
        let a = &m.roads[m.sections[s as usize].road as usize].attributes;
        a.tunnel || a.bridge
    };
    let mut comp: Vec<usize> = (0..m.nodes.len()).collect();
    fn find(c: &mut [usize], x: usize) -> usize {
        let mut r = x;
        while c[r] != r {
            r = c[r];
        }
        c[x] = r;
        r
    }
    for (s, sec) in m.sections.iter().enumerate() {
        if structure(s as u32) {
            let (a, b) = (
                find(&mut comp, sec.start as usize),
                find(&mut comp, sec.end as usize),
            );
            comp[a] = b;
        }
    }
    let mut range: std::collections::HashMap<usize, (f64, f64)> = Default::default();
    for (s, sec) in m.sections.iter().enumerate() {
        if !structure(s as u32) {
            continue;
        }
        for n in [sec.start, sec.end] {
            let inc = net.topology.incidences(n);
            if inc.len() < 2 || inc.iter().any(|i| !structure(i.section)) {
                let [lat, lon] = m.nodes[n as usize].lat_lon;
                let h = dem.height(lat, lon).unwrap();
                let c = find(&mut comp, n as usize);
                let r = range.entry(c).or_insert((f64::MAX, f64::MIN));
                *r = (r.0.min(h), r.1.max(h));
            }
        }
    }
    let mut out = std::collections::HashMap::new();
    for (s, sec) in m.sections.iter().enumerate() {
        if structure(s as u32) {
            let c = find(&mut comp, sec.start as usize);
            if let Some(&r) = range.get(&c) {
                out.insert(m.roads[sec.road as usize].attributes.id.clone(), r);
            }
        }
    }
    out
}

/// An area plan with a DEM: every new tag's height is the road's at its
/// lane: on ordinary roads the plane's at the centre line beside it (the
/// tag is ≤ ~5 m off it: 0.25 m at 5 %); in tunnels the interpolation
/// between the structure's portals, which (a harmonic interpolation) lies
/// within the portals' heights: the maximum principle. (On a plane it is
/// the plane only along a single chain: at a junction of several tunnels
/// the length-weighted mean of the neighbours is not the plane's value;
/// Helsinki's service-tunnel junctions are off it by up to 5.5 m.)
#[test]
fn area_plans_take_terrain_heights() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    write_dem(&d.join("dem.tif"), helsinki(), plane);
    let text = std::fs::read_to_string(repo("scenarios/helsinki-network-plan.toml"))
        .unwrap()
        .replace(
            "path = \"../maps/helsinki.osm.pbf\"",
            &format!(
                "path = \"{}\"\nelevation = \"dem.tif\"",
                repo("maps/helsinki.osm.pbf").display()
            ),
        )
        .replace("validation_runs = 100", "validation_runs = 2");
    std::fs::write(d.join("area.toml"), text).unwrap();
    let out = run(&["plan", "area.toml", "--out", "out", "-q"], d);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let plan: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("out/plan.json")).unwrap()).unwrap();
    let net = Network::load(&repo("maps/helsinki.osm.pbf"), &Default::default()).unwrap();
    let dem = Dem::open(&[d.join("dem.tif")]).unwrap();
    let portals = structure_portal_ranges(&net, &dem);
    let tags = plan["tags"].as_array().unwrap();
    let (mut road, mut n_tunnel) = (0.0f64, 0);
    for t in tags.iter().filter(|t| t["existing"] == false) {
        let f = |k: &str| t[k].as_f64().unwrap();
        let h = f("height_m");
        if t["tunnel"] == true {
            n_tunnel += 1;
            let (lo, hi) = portals[t["road_id"].as_str().unwrap()];
            assert!(
                h >= lo - 1e-6 && h <= hi + 1e-6,
                "{t}: {h} outside {lo}..{hi}"
            );
        } else {
            road = road.max((h - plane(f("lat"), f("lon"))).abs());
        }
    }
    eprintln!(
        "{} tags ({n_tunnel} in tunnels): worst {road:.3} m on roads",
        tags.len()
    );
    assert!(tags.len() > 100 && n_tunnel > 10);
    assert!(road < 0.3, "{road}");
    assert_eq!(plan["tag_files"]["heights_known"], true);
    let why = plan["tag_files"]["parameters"]["height_m"]
        .as_str()
        .unwrap();
    assert!(why.contains("dem.tif"), "{why}");
    let csv = std::fs::read_to_string(d.join("out/tags.csv")).unwrap();
    assert!(!csv
        .lines()
        .skip(1)
        .all(|l| l.split(',').nth(3) == Some("0.00")));
    // The validation drove the terrain with the tags at these heights:
    // its chains and the worst walks pass.
    assert!(why.contains("validation drove the same terrain"), "{why}");
    let v = &plan["validation"];
    assert_eq!(v["passed"], true, "{v}");
    assert_eq!(v["design_walks"]["passed"], true, "{v}");
}
