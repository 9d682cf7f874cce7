//! Tag files for installers: CSV, GeoJSON (RFC 7946), KML 2.2 and GPX 1.1.
//!
//! Every file carries every column of `tags.csv` for every tag: GeoJSON as
//! feature properties, KML as each Placemark's `ExtendedData`, GPX in each
//! waypoint's `<extensions>` under the namespace [`GPX_NAMESPACE`]. The
//! metadata (requirement, the models' parameters as the plan used them,
//! the Waymark version) is in the `tags.meta.json` sidecar
//! ([`tags_meta_json`]), GeoJSON's `waymark` foreign member, the KML
//! Document's `ExtendedData` and the GPX `metadata`; `tags.csv` holds none,
//! so its first line is its header (GIS tools take it as such).
//! Coordinates are WGS-84 degrees with 7 decimals (1 cm); heights,
//! chainages and offsets with 2 (cm), fix sigmas with 3 (mm). Heights are
//! written as altitudes (KML `altitudeMode` absolute, GPX `ele`, GeoJSON's
//! third coordinate) only when [`ExportMetadata::heights_known`]; otherwise
//! KML clamps to the ground with no altitude, GPX has no `ele`, GeoJSON
//! points are 2-D, and every file's metadata says so (`heights_known`
//! false, `heights_source` "none", the `height_m` parameter why); the
//! `height_m` column keeps the placeholder it was given.
//!
//! GeoJSON and KML are built as the `geojson` and `kml` crates' types and
//! written by those crates; GPX with `quick-xml` (the `gpx` crate writes
//! no extensions).

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
    "reason",
];

fn opt_f(v: Option<f64>, decimals: usize) -> String {
    v.map(|x| format!("{x:.decimals$}")).unwrap_or_default()
}

/// The namespace of the GPX waypoints' `<extensions>` (prefix `waymark`).
pub const GPX_NAMESPACE: &str = "urn:waymark:gpx:tags:1";

/// A tag's columns, as `tags.csv` writes them (in [`CSV_COLUMNS`] order).
pub fn csv_row(t: &TagRecord) -> [String; 13] {
    [
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
        t.reason.clone().unwrap_or_default(),
    ]
}

/// Where the tags' heights come from, as the files' metadata states it
/// (`heights_source`): `"none"` when they are not known (placeholders: the
/// route's constant height, 0 m unless the scenario sets one; KML then
/// clamps to the ground, GPX has no `ele`, GeoJSON points are 2-D),
/// `"elevation_model"` when a DEM gave them (the plan's `height_m`
/// parameter names it), else `"trajectory"` (a drive by motion commands).
pub fn heights_source(meta: &ExportMetadata) -> &'static str {
    meta.heights_source()
}

/// Writes `tags.meta.json`: the metadata of the tag files (version,
/// requirement, parameters as the plan used them, attribution, whether
/// heights are real) and the columns of `tags.csv`.
pub fn tags_meta_json(meta: &ExportMetadata) -> String {
    let mut v = serde_json::to_value(meta).unwrap_or_default();
    v["columns"] = CSV_COLUMNS.iter().map(|c| JsonValue::from(*c)).collect();
    v["crs"] = "WGS 84 (EPSG:4326), degrees; heights in metres".into();
    v["heights_source"] = heights_source(meta).into();
    serde_json::to_string_pretty(&v).unwrap_or_default()
}

/// Writes `tags.csv`: a header row, then one row per tag (no metadata
/// lines: those are in `tags.meta.json`).
pub fn tags_csv(tags: &[TagRecord], _meta: &ExportMetadata) -> String {
    let mut out = String::new();
    let mut w = csv::WriterBuilder::new().from_writer(Vec::new());
    let _ = w.write_record(CSV_COLUMNS);
    for t in tags {
        let row = csv_row(t);
        let _ = w.write_record(&row);
    }
    let body = w.into_inner().unwrap_or_default();
    out.push_str(&String::from_utf8_lossy(&body));
    out
}

/// `x` as written with `decimals` decimals, read back (so a crate printing
/// the shortest form of a float prints those digits).
fn printed(x: f64, decimals: usize) -> f64 {
    format!("{x:.decimals$}").parse().unwrap_or(x)
}

/// Writes `tags.geojson`: a FeatureCollection of Points `[lon, lat, height]`
/// (`[lon, lat]` when the heights are not known).
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
            put("height_m", printed(t.height_m, 2).into());
            put("chainage_m", t.chainage_m.map(|c| printed(c, 2)).into());
            put("side", t.side.clone().into());
            put(
                "lateral_offset_m",
                t.lateral_offset_m.map(|c| printed(c, 2)).into(),
            );
            put("mounting", t.mounting.as_str().into());
            put(
                "expected_fix_sigma_m",
                t.expected_fix_sigma_m.map(|c| printed(c, 3)).into(),
            );
            put("redundancy_group", t.redundancy_group.into());
            put("payload_hex", t.payload_hex.clone().into());
            put("reason", t.reason.clone().into());
            Feature {
                bbox: None,
                // A height only when known: a third coordinate of 0 m
                // would read as a real (ellipsoidal) height in a GIS.
                geometry: Some(Geometry::new(geojson::Value::Point(
                    [printed(t.lon, 7), printed(t.lat, 7)]
                        .into_iter()
                        .chain(meta.heights_known.then(|| printed(t.height_m, 2)))
                        .collect(),
                ))),
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
        b.map(|x| printed(x, 7)).to_vec()
    });
    let mut foreign = JsonObject::new();
    let mut waymark = serde_json::to_value(meta).unwrap_or_default();
    waymark["heights_source"] = heights_source(meta).into();
    foreign.insert("waymark".to_owned(), waymark);
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
    // KML 2.2's order for a Document: name, description, styles
    // (StyleSelector), ExtendedData, then the features (schema-validating
    // readers such as fastkml reject another order).
    let mut doc: Vec<Kml> = vec![
        Kml::Element(text_element("name", "Waymark RFID tags")),
        Kml::Element(text_element("description", meta.lines().join("; "))),
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
    doc.push(Kml::Element(extended_data(
        std::iter::once(("waymark_version", meta.waymark_version.clone()))
            .chain(meta.requirement_m.map(|r| ("requirement_m", r.to_string())))
            .chain([
                ("heights_known", meta.heights_known.to_string()),
                ("heights_source", heights_source(meta).to_string()),
            ])
            .chain(meta.parameters.iter().map(|(k, v)| (k.as_str(), v.clone()))),
    )));
    for t in tags {
        let data = CSV_COLUMNS.iter().copied().zip(csv_row(t));
        let mut point = Point::from(Coord::new(
            printed(t.lon, 7),
            printed(t.lat, 7),
            meta.heights_known.then(|| printed(t.height_m, 2)),
        ));
        point.altitude_mode = if meta.heights_known {
            kml::types::AltitudeMode::Absolute
        } else {
            kml::types::AltitudeMode::ClampToGround
        };
        doc.push(Kml::Placemark(kml::types::Placemark {
            name: Some(t.tag_id.clone()),
            description: Some(description(t)),
            // `style_url` would be written after the geometry; KML 2.2 puts
            // `styleUrl` before `ExtendedData`.
            children: vec![
                text_element("styleUrl", format!("#{}", t.mounting)),
                extended_data(data),
            ],
            geometry: Some(kml::types::Geometry::Point(point)),
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

/// Writes `tags.gpx` (GPX 1.1): one waypoint per tag, every column of
/// `tags.csv` in its `<extensions>` (namespace [`GPX_NAMESPACE`]).
pub fn tags_gpx(tags: &[TagRecord], meta: &ExportMetadata) -> String {
    use quick_xml::events::{BytesDecl, BytesEnd, BytesStart, BytesText, Event};
    let mut w = quick_xml::Writer::new_with_indent(Vec::new(), b' ', 2);
    // Writing into a Vec cannot fail.
    let mut ev = |e: Event<'_>| {
        w.write_event(e)
            .expect("writing XML into memory cannot fail");
    };
    let text = |ev: &mut dyn FnMut(Event<'_>), name: &str, value: &str| {
        ev(Event::Start(BytesStart::new(name)));
        ev(Event::Text(BytesText::new(value)));
        ev(Event::End(BytesEnd::new(name)));
    };
    ev(Event::Decl(BytesDecl::new("1.0", Some("UTF-8"), None)));
    let creator = format!("Waymark {}", meta.waymark_version);
    ev(Event::Start(BytesStart::new("gpx").with_attributes([
        ("version", "1.1"),
        ("creator", creator.as_str()),
        ("xmlns", "http://www.topografix.com/GPX/1/1"),
        ("xmlns:waymark", GPX_NAMESPACE),
    ])));
    ev(Event::Start(BytesStart::new("metadata")));
    text(&mut ev, "name", "Waymark RFID tags");
    text(&mut ev, "desc", &meta.lines().join("; "));
    ev(Event::End(BytesEnd::new("metadata")));
    for t in tags {
        let (lat, lon) = (format!("{:.7}", t.lat), format!("{:.7}", t.lon));
        ev(Event::Start(BytesStart::new("wpt").with_attributes([
            ("lat", lat.as_str()),
            ("lon", lon.as_str()),
        ])));
        if meta.heights_known {
            text(&mut ev, "ele", &format!("{:.2}", t.height_m));
        }
        text(&mut ev, "name", &t.tag_id);
        text(&mut ev, "desc", &description(t));
        text(&mut ev, "type", t.mounting.as_str());
        ev(Event::Start(BytesStart::new("extensions")));
        for (col, value) in CSV_COLUMNS.iter().zip(csv_row(t)) {
            text(&mut ev, &format!("waymark:{col}"), &value);
        }
        ev(Event::End(BytesEnd::new("extensions")));
        ev(Event::End(BytesEnd::new("wpt")));
    }
    ev(Event::End(BytesEnd::new("gpx")));
    let mut out = w.into_inner();
    out.push(b'\n');
    String::from_utf8(out).expect("the XML writer writes UTF-8")
}
