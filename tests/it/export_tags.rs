//! Tag exports open in standard tools: the GeoJSON follows RFC 7946 and parses
//! with `geojson`, the KML parses with `kml`, the GPX with `gpx`, the CSV with
//! a strict-header `csv` reader (its first line is its header); every file
//! carries every column of `tags.csv` for every tag, the metadata is in the
//! `tags.meta.json` sidecar (and GeoJSON/KML/GPX document metadata), and
//! the positions round-trip.

use waymark::export::{
    csv_row, tags_csv, tags_geojson, tags_gpx, tags_kml, tags_meta_json, ExportMetadata, TagRecord,
    CSV_COLUMNS, GPX_NAMESPACE,
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
            // Chainages with float noise: written at 1 cm.
            chainage_m: Some(10.0 * i as f64 + 0.123456789012),
            side: Some("right".into()),
            lateral_offset_m: Some(1.5),
            mounting: m,
            expected_fix_sigma_m: Some(0.5),
            redundancy_group: Some(i as u32 / 2),
            reason: Some(format!("stretch {i}, \"quoted\" & <odd>")),
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
    meta.heights_known = true;
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
    // Strict: no comment lines allowed, the first line is the header (as
    // GDAL and QGIS read it).
    assert_eq!(text.lines().next().unwrap(), CSV_COLUMNS.join(","));
    let mut r = csv::ReaderBuilder::new()
        .has_headers(true)
        .flexible(false)
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
        assert_eq!(&row[5], format!("{:.2}", t.chainage_m.unwrap()));
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

/// Every tag's columns as `tags.csv` writes them.
fn expected_columns(tags: &[TagRecord]) -> Vec<Vec<(String, String)>> {
    tags.iter()
        .map(|t| {
            CSV_COLUMNS
                .iter()
                .map(|c| c.to_string())
                .zip(csv_row(t))
                .collect()
        })
        .collect()
}

#[test]
fn kml_extended_data_holds_every_column_and_heights_are_absolute() {
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
    for (p, want) in placemarks.iter().zip(expected_columns(&tags)) {
        let ext = p
            .children
            .iter()
            .find(|e| e.name == "ExtendedData")
            .expect("ExtendedData");
        let got: Vec<(String, String)> = ext
            .children
            .iter()
            .filter(|d| d.name == "Data")
            .map(|d| {
                (
                    d.attrs["name"].clone(),
                    d.children[0].content.clone().unwrap_or_default(),
                )
            })
            .collect();
        assert_eq!(got, want);
        let Some(kml::types::Geometry::Point(pt)) = &p.geometry else {
            panic!("no point")
        };
        assert_eq!(pt.altitude_mode, kml::types::AltitudeMode::Absolute);
        assert!(pt.coord.z.is_some());
    }
}

#[test]
fn without_known_heights_kml_clamps_to_ground_and_gpx_has_no_elevation() {
    let (tags, mut meta) = sample();
    meta.heights_known = false;
    let k: kml::Kml = tags_kml(&tags, &meta).parse().unwrap();
    let text = k.to_string();
    assert!(text.contains("clampToGround"), "{text}");
    let g = gpx::read(tags_gpx(&tags, &meta).as_bytes()).unwrap();
    assert!(g.waypoints.iter().all(|w| w.elevation.is_none()));
    // No altitude in any Point (KML's default altitude would be 0 m).
    assert!(
        text.matches("<coordinates>")
            .zip(text.split("<coordinates>").skip(1))
            .all(|(_, c)| c[..c.find('<').unwrap()].split(',').count() == 2),
        "{text}"
    );
    // GeoJSON points are 2-D: a third coordinate would read as a real height.
    let gj: serde_json::Value = serde_json::from_str(&tags_geojson(&tags, &meta)).unwrap();
    for f in gj["features"].as_array().unwrap() {
        assert_eq!(f["geometry"]["coordinates"].as_array().unwrap().len(), 2);
    }
    assert_eq!(gj["waymark"]["heights_source"], "none");
    // The sidecar and the KML document's metadata say so.
    let m: serde_json::Value = serde_json::from_str(&tags_meta_json(&meta)).unwrap();
    assert_eq!(m["heights_known"], false);
    assert_eq!(m["heights_source"], "none");
    assert!(text.contains("<Data name=\"heights_source\"><value>none</value></Data>"));
    // Known heights: 3-D GeoJSON; where they came from.
    meta.heights_known = true;
    let gj: serde_json::Value = serde_json::from_str(&tags_geojson(&tags, &meta)).unwrap();
    assert_eq!(gj["features"][0]["geometry"]["coordinates"][2], 12.5);
    let m: serde_json::Value = serde_json::from_str(&tags_meta_json(&meta)).unwrap();
    assert_eq!(m["heights_source"], "trajectory");
    meta.parameters.insert(
        "height_m".into(),
        "the terrain's, from the elevation model dem.tif".into(),
    );
    let m: serde_json::Value = serde_json::from_str(&tags_meta_json(&meta)).unwrap();
    assert_eq!(m["heights_source"], "elevation_model");
}

/// The direct children of each element named `parent`, by local name.
fn children_of(xml: &str, parent: &str) -> Vec<Vec<String>> {
    use quick_xml::events::Event;
    let mut r = quick_xml::Reader::from_str(xml);
    let (mut stack, mut out): (Vec<String>, Vec<Vec<String>>) = (Vec::new(), Vec::new());
    loop {
        match r.read_event().unwrap() {
            Event::Start(e) => {
                let name = String::from_utf8(e.local_name().as_ref().to_vec()).unwrap();
                if stack.last().is_some_and(|p| p == parent) {
                    out.last_mut().unwrap().push(name.clone());
                }
                if name == parent {
                    out.push(Vec::new());
                }
                stack.push(name);
            }
            Event::Empty(e) => {
                let name = String::from_utf8(e.local_name().as_ref().to_vec()).unwrap();
                if stack.last().is_some_and(|p| p == parent) {
                    out.last_mut().unwrap().push(name);
                }
            }
            Event::End(_) => {
                stack.pop();
            }
            Event::Eof => break,
            _ => {}
        }
    }
    out
}

#[test]
fn kml_elements_are_in_the_order_kml_2_2_prescribes() {
    // The OGC KML 2.2 schema's sequences (ogckml22.xsd): a Feature's
    // name, description, styleUrl, StyleSelector (Style), ExtendedData, then
    // a Document's Features or a Placemark's Geometry; a Point's extrude,
    // altitudeMode, coordinates. Schema-validating readers (fastkml with
    // lxml) reject other orders; the `kml` crate does not check.
    let rank = |order: &[&str], got: &[String]| -> Vec<usize> {
        got.iter()
            .map(|n| {
                order
                    .iter()
                    .position(|o| o == n)
                    .unwrap_or_else(|| panic!("unexpected <{n}>"))
            })
            .collect()
    };
    for known in [true, false] {
        let (tags, mut meta) = sample();
        meta.heights_known = known;
        let text = tags_kml(&tags, &meta);
        let doc = &children_of(&text, "Document")[0];
        let r = rank(
            &["name", "description", "Style", "ExtendedData", "Placemark"],
            doc,
        );
        assert!(r.windows(2).all(|w| w[0] <= w[1]), "{doc:?}");
        for pm in children_of(&text, "Placemark") {
            let r = rank(
                &["name", "description", "styleUrl", "ExtendedData", "Point"],
                &pm,
            );
            assert!(r.windows(2).all(|w| w[0] < w[1]), "{pm:?}");
        }
        for pt in children_of(&text, "Point") {
            assert_eq!(pt, ["extrude", "altitudeMode", "coordinates"]);
        }
    }
}

#[test]
fn gpx_extensions_hold_every_column() {
    use quick_xml::events::Event;
    let (tags, meta) = sample();
    let text = tags_gpx(&tags, &meta);
    assert!(text.contains(&format!("xmlns:waymark=\"{GPX_NAMESPACE}\"")));
    // The gpx crate reads it (and skips the extensions) ...
    assert_eq!(gpx::read(text.as_bytes()).unwrap().waypoints.len(), 3);
    // ... and a namespace-aware reader finds every column in them.
    let mut r = quick_xml::NsReader::from_str(&text);
    let mut got: Vec<Vec<(String, String)>> = Vec::new();
    let mut current: Option<String> = None;
    loop {
        match r.read_resolved_event().unwrap() {
            (_, Event::Start(e)) if e.local_name().as_ref() == b"wpt" => got.push(Vec::new()),
            (quick_xml::name::ResolveResult::Bound(ns), Event::Start(e))
                if ns.as_ref() == GPX_NAMESPACE.as_bytes() =>
            {
                current = Some(String::from_utf8(e.local_name().as_ref().to_vec()).unwrap());
            }
            (_, Event::Text(t)) if current.is_some() => {
                let v = t.unescape().unwrap().to_string();
                got.last_mut().unwrap().push((current.take().unwrap(), v));
            }
            (_, Event::End(_)) if current.is_some() => {
                // An empty element: an empty column.
                got.last_mut()
                    .unwrap()
                    .push((current.take().unwrap(), String::new()));
            }
            (_, Event::Eof) => break,
            _ => {}
        }
    }
    assert_eq!(got, expected_columns(&tags));
}

#[test]
fn geojson_numbers_are_at_sensible_precision() {
    let (tags, meta) = sample();
    let text = tags_geojson(&tags, &meta);
    let v: serde_json::Value = serde_json::from_str(&text).unwrap();
    for (f, want) in v["features"]
        .as_array()
        .unwrap()
        .iter()
        .zip(expected_columns(&tags))
    {
        let p = &f["properties"];
        // Every column is a property (positions also as the geometry).
        let c = &f["geometry"]["coordinates"];
        for (col, value) in &want {
            let got = match col.as_str() {
                "lat" => &c[1],
                "lon" => &c[0],
                k => &p[k],
            };
            match got {
                serde_json::Value::Number(n) => {
                    let printed = n.to_string();
                    let decimals = printed.split('.').nth(1).map_or(0, str::len);
                    assert!(decimals <= 7, "{col}: {printed}");
                    assert!(
                        (n.as_f64().unwrap() - value.parse::<f64>().unwrap()).abs() < 1e-9,
                        "{col}: {printed} vs {value}"
                    );
                }
                serde_json::Value::String(s) => assert_eq!(s, value, "{col}"),
                serde_json::Value::Null => assert!(value.is_empty(), "{col}"),
                other => panic!("{col}: {other}"),
            }
        }
        let chainage = p["chainage_m"].to_string();
        assert!(
            chainage.split('.').nth(1).map_or(0, str::len) <= 2,
            "{chainage}"
        );
    }
}

#[test]
fn sidecar_holds_the_metadata_and_the_columns() {
    let (_, meta) = sample();
    let m: serde_json::Value = serde_json::from_str(&tags_meta_json(&meta)).unwrap();
    assert_eq!(m["requirement_m"], 20.0);
    assert_eq!(m["parameters"]["imu"], "tactical <1 deg/h>");
    assert_eq!(m["columns"].as_array().unwrap().len(), CSV_COLUMNS.len());
}
