//! Tag files for installers: CSV, GeoJSON (RFC 7946), KML 2.2 and GPX 1.1.
//!
//! Every file carries the requirement, the models' parameters and the Waymark
//! version: CSV as leading `#` comment lines, GeoJSON as a `waymark` foreign
//! member of the FeatureCollection, KML as `ExtendedData` of the Document, GPX
//! in its `metadata`. Coordinates are WGS-84 degrees with 7 decimals (1 cm).
//!
//! The documents are built as the `geojson`, `kml` and `gpx` crates' types and
//! written by those crates.

use crate::tags::{ExportMetadata, Mounting, TagRecord};
use geojson::{feature::Id, Feature, FeatureCollection, Geometry, JsonObject, JsonValue};
use kml::types::{Coord, Element, Point};
use kml::{Kml, KmlDocument, KmlVersion, KmlWriter};
use std::collections::HashMap;
use std::fmt::Write;

/// The CSV header, in column order.
pub const CSV_COLUMNS: &[&str] = &[
    "tag_id",
    "lat",
    "lon",
    "height_m",
    "road_id",
    "chainage_m",
    "side",
    "lateral_offset_m",
    "mounting",
    "expected_fix_sigma_m",
    "redundancy_group",
    "payload_hex",
];

fn opt_f(v: Option<f64>, decimals: usize) -> String {
    v.map(|x| format!("{x:.decimals$}")).unwrap_or_default()
}

/// Writes `tags.csv`: `#` metadata lines, then a header row and one row per tag.
pub fn tags_csv(tags: &[TagRecord], meta: &ExportMetadata) -> String {
    let mut out = String::new();
    for l in meta.lines() {
        let _ = writeln!(out, "# {l}");
    }
    let mut w = csv::WriterBuilder::new().from_writer(Vec::new());
    let _ = w.write_record(CSV_COLUMNS);
    for t in tags {
        let row = [
            t.tag_id.clone(),
            format!("{:.7}", t.lat),
            format!("{:.7}", t.lon),
            format!("{:.2}", t.height_m),
            t.road_id.clone().unwrap_or_default(),
            opt_f(t.chainage_m, 2),
            t.side.clone().unwrap_or_default(),
            opt_f(t.lateral_offset_m, 2),
            t.mounting.to_string(),
            opt_f(t.expected_fix_sigma_m, 3),
            t.redundancy_group
                .map(|g| g.to_string())
                .unwrap_or_default(),
            t.payload_hex.clone().unwrap_or_default(),
        ];
        let _ = w.write_record(&row);
    }
    let body = w.into_inner().unwrap_or_default();
    out.push_str(&String::from_utf8_lossy(&body));
    out
}

fn round7(x: f64) -> f64 {
    (x * 1e7).round() / 1e7
}

/// `x` as written with `decimals` decimals, read back (so a crate printing
/// the shortest form of a float prints those digits).
fn printed(x: f64, decimals: usize) -> f64 {
    format!("{x:.decimals$}").parse().unwrap_or(x)
}

/// Writes `tags.geojson`: a FeatureCollection of Points `[lon, lat, height]`.
pub fn tags_geojson(tags: &[TagRecord], meta: &ExportMetadata) -> String {
    let features: Vec<Feature> = tags
        .iter()
        .map(|t| {
            let mut properties = JsonObject::new();
            let mut put = |k: &str, v: JsonValue| {
                properties.insert(k.to_owned(), v);
            };
            put("tag_id", t.tag_id.clone().into());
            put("road_id", t.road_id.clone().into());
            put("chainage_m", t.chainage_m.into());
            put("side", t.side.clone().into());
            put("lateral_offset_m", t.lateral_offset_m.into());
            put("mounting", t.mounting.as_str().into());
            put("expected_fix_sigma_m", t.expected_fix_sigma_m.into());
            put("redundancy_group", t.redundancy_group.into());
            put("payload_hex", t.payload_hex.clone().into());
            Feature {
                bbox: None,
                geometry: Some(Geometry::new(geojson::Value::Point(vec![
                    round7(t.lon),
                    round7(t.lat),
                    (t.height_m * 100.0).round() / 100.0,
                ]))),
                id: Some(Id::String(t.tag_id.clone())),
                properties: Some(properties),
                foreign_members: None,
            }
        })
        .collect();
    let bbox = (!tags.is_empty()).then(|| {
        let mut b = [f64::MAX, f64::MAX, f64::MIN, f64::MIN];
        for t in tags {
            b = [
                b[0].min(t.lon),
                b[1].min(t.lat),
                b[2].max(t.lon),
                b[3].max(t.lat),
            ];
        }
        b.map(round7).to_vec()
    });
    let mut foreign = JsonObject::new();
    foreign.insert(
        "waymark".to_owned(),
        serde_json::to_value(meta).unwrap_or_default(),
    );
    let fc = FeatureCollection {
        bbox,
        features,
        foreign_members: Some(foreign),
    };
    serde_json::to_string_pretty(&fc).unwrap_or_default()
}

fn description(t: &TagRecord) -> String {
    let mut d = format!("mounting {}", t.mounting);
    if let Some(r) = &t.road_id {
        let _ = write!(d, ", road {r}");
    }
    if let Some(c) = t.chainage_m {
        let _ = write!(d, ", chainage {c:.1} m");
    }
    if let Some(s) = &t.side {
        let _ = write!(d, ", {s} side");
    }
    if let Some(s) = t.expected_fix_sigma_m {
        let _ = write!(d, ", fix sigma {s:.2} m");
    }
    if let Some(p) = &t.payload_hex {
        let _ = write!(d, ", payload {p}");
    }
    d
}

/// A KML element with text content.
fn text_element(name: &str, content: impl Into<String>) -> Element {
    Element {
        name: name.to_owned(),
        content: Some(content.into()),
        ..Default::default()
    }
}

/// A KML element with one attribute and child elements.
fn parent_element(name: &str, attr: Option<(&str, &str)>, children: Vec<Element>) -> Element {
    Element {
        name: name.to_owned(),
        attrs: attr
            .map(|(k, v)| HashMap::from([(k.to_owned(), v.to_owned())]))
            .unwrap_or_default(),
        content: None,
        children,
    }
}

/// `<ExtendedData>` with one `<Data name=".."><value>..</value></Data>` per pair.
fn extended_data<'a>(pairs: impl IntoIterator<Item = (&'a str, String)>) -> Element {
    let data = pairs
        .into_iter()
        .map(|(k, v)| parent_element("Data", Some(("name", k)), vec![text_element("value", v)]))
        .collect();
    parent_element("ExtendedData", None, data)
}

/// Writes `tags.kml` (KML 2.2): one Placemark per tag, a style per mounting.
pub fn tags_kml(tags: &[TagRecord], meta: &ExportMetadata) -> String {
    let mut doc: Vec<Kml> = vec![
        Kml::Element(text_element("name", "Waymark RFID tags")),
        Kml::Element(text_element("description", meta.lines().join("; "))),
        Kml::Element(extended_data(
            std::iter::once(("waymark_version", meta.waymark_version.clone()))
                .chain(meta.requirement_m.map(|r| ("requirement_m", r.to_string())))
                .chain(meta.parameters.iter().map(|(k, v)| (k.as_str(), v.clone()))),
        )),
    ];
    // Styles as plain elements: `kml::types::Style` always writes an empty
    // `<Icon>`, which hides the placemark's icon in Google Earth.
    for (m, colour) in [
        (Mounting::RoadSurface, "ff00a5ff"),
        (Mounting::Roadside, "ff00ff00"),
        (Mounting::Ceiling, "ffff00ff"),
    ] {
        doc.push(Kml::Element(parent_element(
            "Style",
            Some(("id", m.as_str())),
            vec![parent_element(
                "IconStyle",
                None,
                vec![text_element("color", colour)],
            )],
        )));
    }
    for t in tags {
        let mut data = vec![("mounting", t.mounting.to_string())];
        if let Some(p) = &t.payload_hex {
            data.push(("payload_hex", p.clone()));
        }
        doc.push(Kml::Placemark(kml::types::Placemark {
            name: Some(t.tag_id.clone()),
            description: Some(description(t)),
            // `style_url` would be written after the geometry; KML 2.2 puts
            // `styleUrl` before `ExtendedData`.
            children: vec![
                text_element("styleUrl", format!("#{}", t.mounting)),
                extended_data(data),
            ],
            geometry: Some(kml::types::Geometry::Point(Point::from(Coord::new(
                printed(t.lon, 7),
                printed(t.lat, 7),
                Some(printed(t.height_m, 2)),
            )))),
            ..Default::default()
        }));
    }
    let kml = Kml::KmlDocument(KmlDocument {
        version: KmlVersion::V22,
        attrs: HashMap::from([(
            "xmlns".to_owned(),
            "http://www.opengis.net/kml/2.2".to_owned(),
        )]),
        elements: vec![Kml::Document {
            attrs: HashMap::new(),
            elements: doc,
        }],
    });
    let mut out = b"<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n".to_vec();
    KmlWriter::<_, f64>::from_writer(&mut out)
        .write(&kml)
        .expect("writing KML into memory cannot fail");
    out.push(b'\n');
    String::from_utf8(out).expect("the KML writer writes UTF-8")
}

/// Writes `tags.gpx` (GPX 1.1): one waypoint per tag.
pub fn tags_gpx(tags: &[TagRecord], meta: &ExportMetadata) -> String {
    let waypoints = tags
        .iter()
        .map(|t| {
            let mut w = gpx::Waypoint::new((printed(t.lon, 7), printed(t.lat, 7)).into());
            w.elevation = Some(printed(t.height_m, 2));
            w.name = Some(t.tag_id.clone());
            w.description = Some(description(t));
            w.type_ = Some(t.mounting.to_string());
            w
        })
        .collect();
    let doc = gpx::Gpx {
        version: gpx::GpxVersion::Gpx11,
        creator: Some(format!("Waymark {}", meta.waymark_version)),
        metadata: Some(gpx::Metadata {
            name: Some("Waymark RFID tags".to_owned()),
            description: Some(meta.lines().join("; ")),
            ..Default::default()
        }),
        waypoints,
        ..Default::default()
    };
    let mut out = Vec::new();
    gpx::write(&doc, &mut out).expect("writing GPX 1.1 into memory cannot fail");
    out.push(b'\n');
    String::from_utf8(out).expect("the GPX writer writes UTF-8")
}
