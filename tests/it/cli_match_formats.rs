//! `waymark match` on GPX and GeoJSON tracks, the complete path files, and
//! bad input: one clear line naming the file or the option, exit 1 (2 for
//! a bad option value).

use std::path::Path;
use std::process::{Command, Output};

fn map() -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("maps/helsinki.osm.pbf")
        .display()
        .to_string()
}

fn run(dir: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_waymark"))
        .arg("match")
        .args(["--map", &map()])
        .args(args)
        .current_dir(dir)
        .output()
        .unwrap()
}

fn one_line_error(out: &Output, code: i32, needles: &[&str]) {
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(code), "{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    if code == 1 {
        assert_eq!(stderr.trim_end().lines().count(), 1, "{stderr}");
    }
    for n in needles {
        assert!(stderr.contains(n), "{n}: {stderr}");
    }
}

/// Points every 150 m (3 m noise, seeded) along a 2.2 km route across
/// Helsinki, and the route's length.
fn points() -> (Vec<(f64, f64)>, f64) {
    use waymark::matching::{along_route, TrackModel};
    let net = waymark::network::Network::load(Path::new(&map()), &Default::default()).unwrap();
    let route =
        waymark::route::plan_route(&net, &[[60.1660, 24.9380], [60.1770, 24.9510]]).unwrap();
    let track = along_route(
        &net,
        &route,
        &TrackModel {
            spacing_m: 150.0,
            speed_mps: 10.0,
            drift_max_m: 0.0,
            noise_sigma_m: 3.0,
            heading_sigma_deg: None,
            seed: 4,
        },
    );
    let pts = track
        .fixes
        .iter()
        .map(|f| {
            let g = net.frame.to_geodetic([f.enu[0], f.enu[1], 0.0]);
            (g.lat_deg(), g.lon_deg())
        })
        .collect();
    (pts, route.length_m)
}

fn gpx(times: bool) -> String {
    let pts: String = points()
        .0
        .iter()
        .enumerate()
        .map(|(i, (lat, lon))| {
            let t = if times {
                format!(
                    "<time>2024-05-01T10:{:02}:{:02}Z</time>",
                    i / 4,
                    15 * (i % 4)
                )
            } else {
                String::new()
            };
            format!("<trkpt lat=\"{lat}\" lon=\"{lon}\">{t}</trkpt>")
        })
        .collect();
    format!(
        "<?xml version=\"1.0\"?>\n<gpx version=\"1.1\" creator=\"test\" xmlns=\"http://www.topografix.com/GPX/1/1\"><trk><name/><trkseg>{pts}</trkseg><trkseg>{pts}</trkseg></trk></gpx>"
    )
}

#[test]
fn gpx_and_geojson_tracks_with_complete_paths() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for (name, text) in [
        ("t.gpx", gpx(true)),
        ("notime.gpx", gpx(false)),
        (
            "t.geojson",
            format!(
                "{{\"type\":\"FeatureCollection\",\"features\":[{{\"type\":\"Feature\",\"properties\":{{\"name\":\"a\"}},\"geometry\":{{\"type\":\"LineString\",\"coordinates\":[{}]}}}}]}}",
                points()
                    .0
                    .iter()
                    .map(|(lat, lon)| format!("[{lon},{lat}]"))
                    .collect::<Vec<_>>()
                    .join(",")
            ),
        ),
    ] {
        std::fs::write(d.join(name), text).unwrap();
        let out = run(
            d,
            &[
                "--track",
                name,
                "--out",
                "m.csv",
                "--path",
                "out/p.csv",
                "--path-geojson",
                "out/p.geojson",
                "--json",
            ],
        );
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "{name}: {stderr}");
        let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        let gpx = name.ends_with(".gpx");
        assert_eq!(json["format"], if gpx { "gpx" } else { "geojson" });
        // Two segments: two tracks, each one piece.
        let tracks = if gpx { 2 } else { 1 };
        assert_eq!(json["tracks"], tracks, "{name}");
        assert_eq!(json["matched_share"], 1.0, "{name}");
        assert_eq!(json["path_pieces"], tracks, "{name}");
        // The route's length, to the projections of the first and last
        // points (3 m noise) and a few metres of different lanes' geometry.
        let route_len = points().1;
        let len = json["path_length_m"].as_f64().unwrap() / tracks as f64;
        assert!((len - route_len).abs() < 0.02 * route_len, "{name}: {len} {route_len}");
        let path = std::fs::read_to_string(d.join("out/p.csv")).unwrap();
        let rows: Vec<&str> = path.lines().skip(1).collect();
        assert!(!rows.is_empty());
        let total: f64 = rows
            .iter()
            .map(|r| r.rsplit(',').next().unwrap().parse::<f64>().unwrap())
            .sum();
        assert!((total - len * tracks as f64).abs() < 0.1 * tracks as f64);
        let gj: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(d.join("out/p.geojson")).unwrap())
                .unwrap();
        let features = gj["features"].as_array().unwrap();
        assert_eq!(features.len(), tracks);
        assert_eq!(features[0]["geometry"]["type"], "LineString");
        assert!(!features[0]["properties"]["roads"].as_array().unwrap().is_empty());
        // MATCHED.csv: the times, or empty where the file gives none.
        let m = std::fs::read_to_string(d.join("m.csv")).unwrap();
        let t = m.lines().nth(1).unwrap().split(',').nth(1).unwrap().to_owned();
        assert_eq!(t.is_empty(), name != "t.gpx", "{name}: {t}");
    }
}

#[test]
fn bad_tracks_and_options_give_one_clear_error() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let w = |name: &str, text: &str| std::fs::write(d.join(name), text).unwrap();
    w(
        "wpt.gpx",
        "<?xml version=\"1.0\"?><gpx version=\"1.1\" creator=\"t\"><wpt lat=\"60.17\" lon=\"24.94\"></wpt></gpx>",
    );
    one_line_error(
        &run(d, &["--track", "wpt.gpx"]),
        1,
        &["wpt.gpx", "no track points"],
    );
    w("bad.gpx", "<gpx><trk><trkseg><trkpt lat=\"x\"");
    one_line_error(
        &run(d, &["--track", "bad.gpx"]),
        1,
        &["bad.gpx", "not a readable GPX"],
    );
    w(
        "pts.geojson",
        "{\"type\":\"FeatureCollection\",\"features\":[{\"type\":\"Feature\",\"properties\":{},\"geometry\":{\"type\":\"Polygon\",\"coordinates\":[[[24.9,60.1],[24.9,60.2],[25,60.2],[24.9,60.1]]]}}]}",
    );
    one_line_error(
        &run(d, &["--track", "pts.geojson"]),
        1,
        &[
            "pts.geojson",
            "no LineString, MultiLineString or MultiPoint",
        ],
    );
    let back = gpx(true).replacen("10:00:00Z", "10:30:00Z", 1);
    w("back.gpx", &back);
    one_line_error(
        &run(d, &["--track", "back.gpx"]),
        1,
        &["back.gpx", "track 1.1, point 2: time goes back"],
    );
    w("t.gpx", &gpx(true));
    for (opt, v) in [
        ("--radius-m", "0"),
        ("--sigma-m", "1000"),
        ("--max-speed-kmh", "nan"),
        ("--max-gap-s", "0"),
        ("--max-gap-m", "1e9"),
    ] {
        let out = run(d, &["--track", "t.gpx", opt, v]);
        one_line_error(&out, 2, &[opt]);
    }
    assert!(!d.join("matched.csv").exists());
}

#[test]
fn a_geojson_time_that_cannot_be_read_is_an_error() {
    // An unreadable `times` entry was taken as "no time" without a word (the
    // point matched by distance alone, its t_s empty in MATCHED.csv).
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let track = |times: &str| {
        format!(
            r#"{{"type":"FeatureCollection","features":[{{"type":"Feature",
            "properties":{{"times":{times}}},"geometry":{{"type":"LineString",
            "coordinates":[[24.9380,60.1660],[24.93801,60.16601]]}}}}]}}"#
        )
    };
    for (times, needle) in [
        (r#"["2024-01-01T00:00:00Z","garbage"]"#, r#"time "garbage""#),
        (r#"[0,"NaN"]"#, r#"time "NaN""#),
        (r#"[0,{"t":1}]"#, "point 2: time"),
    ] {
        std::fs::write(d.join("t.geojson"), track(times)).unwrap();
        let out = run(d, &["--track", "t.geojson", "--out", "m.csv"]);
        one_line_error(&out, 1, &["t.geojson", "track 1, point 2", needle]);
        assert!(!d.join("m.csv").exists());
    }
    // Null is no time, as before; numbers and RFC 3339 strings are read.
    std::fs::write(
        d.join("t.geojson"),
        track(r#"["2024-01-01T00:00:00Z",null]"#),
    )
    .unwrap();
    let out = run(d, &["--track", "t.geojson", "--out", "m.csv"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}
