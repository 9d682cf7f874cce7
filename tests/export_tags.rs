//! Tag exports open in standard tools: the GeoJSON follows RFC 7946 and parses
//! with `geojson`, the KML parses with `kml`, the GPX with `gpx`, the CSV with
//! `csv`; every file carries the metadata and round-trips the positions.

use waymark::export::{
    tags_csv, tags_geojson, tags_gpx, tags_kml, ExportMetadata, TagRecord, CSV_COLUMNS,
};
use waymark::tags::{Mounting, TagPayload};

fn sample() -> (Vec<TagRecord>, ExportMetadata) {
    let spots = [
        (60.1698571, 24.9383791, 12.5, Mounting::RoadSurface),
        (60.1712345, 24.9412345, -3.25, Mounting::Roadside),
        (-33.8688197, 151.2092955, 40.0, Mounting::Ceiling),
    ];
    let tags = spots
        .iter()
        .enumerate()
        .map(|(i, &(lat, lon, h, m))| TagRecord {
            tag_id: format!("T{i:03}<&\"'>"),
            lat,
            lon,
            height_m: h,
            road_id: Some(format!("way/{}&x", 100 + i)),
            chainage_m: Some(10.0 * i as f64),
            side: Some("right".into()),
            lateral_offset_m: Some(1.5),
            mounting: m,
            expected_fix_sigma_m: Some(0.5),
            redundancy_group: Some(i as u32 / 2),
            payload_hex: Some(
                TagPayload {
                    lat_deg: lat,
                    lon_deg: lon,
                    height_m: h,
                    mounting: m,
                }
                .to_hex()
                .unwrap(),
            ),
        })
        .collect();
    let mut meta = ExportMetadata::new(Some(20.0));
    meta.parameters
        .insert("imu".into(), "tactical <1 deg/h>".into());
    meta.attribution = Some("© OpenStreetMap contributors, ODbL".into());
    (tags, meta)
}

/// The RFC 7946 rules that apply to a FeatureCollection of Points.
fn check_rfc7946(v: &serde_json::Value) {
    assert_eq!(v["type"], "FeatureCollection");
    assert!(v.get("crs").is_none(), "RFC 7946 removed 'crs'");
    let features = v["features"].as_array().expect("features is an array");
    for f in features {
        assert_eq!(f["type"], "Feature");
        assert!(f["id"].is_string() || f["id"].is_number() || f.get("id").is_none());
        assert!(f["properties"].is_object() || f["properties"].is_null());
        let g = &f["geometry"];
        assert_eq!(g["type"], "Point");
        let c = g["coordinates"].as_array().unwrap();
        assert!(
            c.len() == 2 || c.len() == 3,
            "a position has 2 or 3 numbers"
        );
        let (lon, lat) = (c[0].as_f64().unwrap(), c[1].as_f64().unwrap());
        assert!(
            (-180.0..=180.0).contains(&lon) && (-90.0..=90.0).contains(&lat),
            "[lon, lat] order and range"
        );
    }
    if let Some(b) = v.get("bbox") {
        let b: Vec<f64> = b
            .as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap())
            .collect();
        assert_eq!(b.len(), 4);
        assert!(b[0] <= b[2] && b[1] <= b[3]);
        for f in features {
            let c = f["geometry"]["coordinates"].as_array().unwrap();
            let (lon, lat) = (c[0].as_f64().unwrap(), c[1].as_f64().unwrap());
            assert!(lon >= b[0] && lon <= b[2] && lat >= b[1] && lat <= b[3]);
        }
    }
}

#[test]
fn geojson_follows_rfc7946_and_parses() {
    let (tags, meta) = sample();
    let text = tags_geojson(&tags, &meta);
    let v: serde_json::Value = serde_json::from_str(&text).unwrap();
    check_rfc7946(&v);
    assert_eq!(v["waymark"]["requirement_m"], 20.0);
    let parsed: geojson::GeoJson = text.parse().unwrap();
    let geojson::GeoJson::FeatureCollection(fc) = parsed else {
        panic!("not a FeatureCollection")
    };
    assert_eq!(fc.features.len(), 3);
    let geojson::Value::Point(p) = &fc.features[2].geometry.as_ref().unwrap().value else {
        panic!()
    };
    assert!((p[0] - 151.2092955).abs() < 1e-9 && (p[1] + 33.8688197).abs() < 1e-9);
}

#[test]
fn kml_parses_with_the_kml_crate() {
    let (tags, meta) = sample();
    let text = tags_kml(&tags, &meta);
    let k: kml::Kml = text.parse().expect("KML parses");
    let mut placemarks = Vec::new();
    fn walk(k: &kml::Kml, out: &mut Vec<kml::types::Placemark>) {
        match k {
            kml::Kml::KmlDocument(d) => d.elements.iter().for_each(|e| walk(e, out)),
            kml::Kml::Document { elements, .. } => elements.iter().for_each(|e| walk(e, out)),
            kml::Kml::Placemark(p) => out.push(p.clone()),
            _ => {}
        }
    }
    walk(&k, &mut placemarks);
    assert_eq!(placemarks.len(), 3);
    assert_eq!(placemarks[0].name.as_deref(), Some("T000<&\"'>"));
    let Some(kml::types::Geometry::Point(p)) = &placemarks[1].geometry else {
        panic!("no point")
    };
    assert!((p.coord.x - 24.9412345).abs() < 1e-9 && (p.coord.y - 60.1712345).abs() < 1e-9);
    assert!(text.contains("requirement_m"));
}

#[test]
fn gpx_parses_with_the_gpx_crate() {
    let (tags, meta) = sample();
    let text = tags_gpx(&tags, &meta);
    let g = gpx::read(text.as_bytes()).expect("GPX parses");
    assert_eq!(g.waypoints.len(), 3);
    let w = &g.waypoints[0];
    assert!((w.point().y() - 60.1698571).abs() < 1e-9 && (w.point().x() - 24.9383791).abs() < 1e-9);
    assert_eq!(w.elevation, Some(12.5));
    assert_eq!(w.name.as_deref(), Some("T000<&\"'>"));
    assert!(g
        .metadata
        .unwrap()
        .description
        .unwrap()
        .contains("requirement_m = 20"));
}

#[test]
fn csv_round_trips_and_payloads_decode_to_the_rows() {
    let (tags, meta) = sample();
    let text = tags_csv(&tags, &meta);
    assert!(text.starts_with("# Waymark "));
    let mut r = csv::ReaderBuilder::new()
        .comment(Some(b'#'))
        .from_reader(text.as_bytes());
    let header: Vec<String> = r.headers().unwrap().iter().map(str::to_owned).collect();
    assert_eq!(header, CSV_COLUMNS);
    let rows: Vec<csv::StringRecord> = r.records().map(Result::unwrap).collect();
    assert_eq!(rows.len(), 3);
    for (row, t) in rows.iter().zip(&tags) {
        assert_eq!(&row[0], t.tag_id);
        let (lat, lon): (f64, f64) = (row[1].parse().unwrap(), row[2].parse().unwrap());
        assert!((lat - t.lat).abs() < 5e-8 && (lon - t.lon).abs() < 5e-8);
        assert_eq!(&row[8], t.mounting.as_str());
        let p = TagPayload::from_hex(&row[11]).unwrap();
        assert!((p.lat_deg - lat).abs() <= 0.5e-6 && (p.lon_deg - lon).abs() <= 0.5e-6);
        assert_eq!(p.mounting, t.mounting);
    }
}

#[test]
fn exported_csv_is_accepted_as_simulator_input() {
    // The planner's tags.csv (metadata comments, quoted ids) must be readable
    // by `waymark simulate --tags`.
    let (tags, meta) = sample();
    let text = tags_csv(&tags, &meta);
    let read = waymark::sim::tags::parse_tags_csv(std::path::Path::new("tags.csv"), &text).unwrap();
    assert_eq!(read.len(), tags.len());
    for (r, t) in read.iter().zip(&tags) {
        assert_eq!(r.id, t.tag_id);
        assert_eq!(r.mounting, t.mounting);
        assert!((r.lat.to_degrees() - t.lat).abs() < 5e-8);
        assert!((r.height_m.unwrap() - t.height_m).abs() < 5e-3);
    }
}
