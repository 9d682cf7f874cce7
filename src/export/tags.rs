//! Tag files for installers: CSV, GeoJSON (RFC 7946), KML 2.2 and GPX 1.1.
//!
//! Every file carries the requirement, the models' parameters and the Waymark
//! version: CSV as leading `#` comment lines, GeoJSON as a `waymark` foreign
//! member of the FeatureCollection, KML as `ExtendedData` of the Document, GPX
//! in its `metadata`. Coordinates are WGS-84 degrees with 7 decimals (1 cm).

use crate::tags::{ExportMetadata, Mounting, TagRecord};
use quick_xml::escape::escape;
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

/// Writes `tags.geojson`: a FeatureCollection of Points `[lon, lat, height]`.
pub fn tags_geojson(tags: &[TagRecord], meta: &ExportMetadata) -> String {
    let features: Vec<serde_json::Value> = tags
        .iter()
        .map(|t| {
            serde_json::json!({
                "type": "Feature",
                "id": t.tag_id,
                "geometry": {
                    "type": "Point",
                    "coordinates": [round7(t.lon), round7(t.lat), (t.height_m * 100.0).round() / 100.0],
                },
                "properties": {
                    "tag_id": t.tag_id,
                    "road_id": t.road_id,
                    "chainage_m": t.chainage_m,
                    "side": t.side,
                    "lateral_offset_m": t.lateral_offset_m,
                    "mounting": t.mounting,
                    "expected_fix_sigma_m": t.expected_fix_sigma_m,
                    "redundancy_group": t.redundancy_group,
                    "payload_hex": t.payload_hex,
                },
            })
        })
        .collect();
    let mut bbox = [f64::MAX, f64::MAX, f64::MIN, f64::MIN];
    for t in tags {
        bbox = [
            bbox[0].min(t.lon),
            bbox[1].min(t.lat),
            bbox[2].max(t.lon),
            bbox[3].max(t.lat),
        ];
    }
    let mut fc = serde_json::json!({
        "type": "FeatureCollection",
        "waymark": meta,
        "features": features,
    });
    if !tags.is_empty() {
        fc["bbox"] = serde_json::json!(bbox.map(round7));
    }
    serde_json::to_string_pretty(&fc).unwrap_or_default()
}

fn xml(s: &str) -> String {
    escape(s).into_owned()
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

/// Writes `tags.kml` (KML 2.2): one Placemark per tag, a style per mounting.
pub fn tags_kml(tags: &[TagRecord], meta: &ExportMetadata) -> String {
    let mut s = String::new();
    s.push_str("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n");
    s.push_str("<kml xmlns=\"http://www.opengis.net/kml/2.2\">\n<Document>\n");
    let _ = writeln!(s, "  <name>Waymark RFID tags</name>");
    let _ = writeln!(
        s,
        "  <description>{}</description>",
        xml(&meta.lines().join("; "))
    );
    s.push_str("  <ExtendedData>\n");
    let _ = writeln!(
        s,
        "    <Data name=\"waymark_version\"><value>{}</value></Data>",
        xml(&meta.waymark_version)
    );
    if let Some(r) = meta.requirement_m {
        let _ = writeln!(
            s,
            "    <Data name=\"requirement_m\"><value>{r}</value></Data>"
        );
    }
    for (k, v) in &meta.parameters {
        let _ = writeln!(
            s,
            "    <Data name=\"{}\"><value>{}</value></Data>",
            xml(k),
            xml(v)
        );
    }
    s.push_str("  </ExtendedData>\n");
    for (m, colour) in [
        (Mounting::RoadSurface, "ff00a5ff"),
        (Mounting::Roadside, "ff00ff00"),
        (Mounting::Ceiling, "ffff00ff"),
    ] {
        let _ = writeln!(
            s,
            "  <Style id=\"{m}\"><IconStyle><color>{colour}</color></IconStyle></Style>"
        );
    }
    for t in tags {
        s.push_str("  <Placemark>\n");
        let _ = writeln!(s, "    <name>{}</name>", xml(&t.tag_id));
        let _ = writeln!(s, "    <description>{}</description>", xml(&description(t)));
        let _ = writeln!(s, "    <styleUrl>#{}</styleUrl>", t.mounting);
        s.push_str("    <ExtendedData>\n");
        let _ = writeln!(
            s,
            "      <Data name=\"mounting\"><value>{}</value></Data>",
            t.mounting
        );
        if let Some(p) = &t.payload_hex {
            let _ = writeln!(
                s,
                "      <Data name=\"payload_hex\"><value>{}</value></Data>",
                xml(p)
            );
        }
        s.push_str("    </ExtendedData>\n");
        let _ = writeln!(
            s,
            "    <Point><coordinates>{:.7},{:.7},{:.2}</coordinates></Point>",
            t.lon, t.lat, t.height_m
        );
        s.push_str("  </Placemark>\n");
    }
    s.push_str("</Document>\n</kml>\n");
    s
}

/// Writes `tags.gpx` (GPX 1.1): one waypoint per tag.
pub fn tags_gpx(tags: &[TagRecord], meta: &ExportMetadata) -> String {
    let mut s = String::new();
    s.push_str("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n");
    let _ = writeln!(
        s,
        "<gpx version=\"1.1\" creator=\"Waymark {}\" xmlns=\"http://www.topografix.com/GPX/1/1\">",
        xml(&meta.waymark_version)
    );
    s.push_str("  <metadata>\n    <name>Waymark RFID tags</name>\n");
    let _ = writeln!(s, "    <desc>{}</desc>", xml(&meta.lines().join("; ")));
    s.push_str("  </metadata>\n");
    for t in tags {
        let _ = writeln!(s, "  <wpt lat=\"{:.7}\" lon=\"{:.7}\">", t.lat, t.lon);
        let _ = writeln!(s, "    <ele>{:.2}</ele>", t.height_m);
        let _ = writeln!(s, "    <name>{}</name>", xml(&t.tag_id));
        let _ = writeln!(s, "    <desc>{}</desc>", xml(&description(t)));
        let _ = writeln!(s, "    <type>{}</type>", t.mounting);
        s.push_str("  </wpt>\n");
    }
    s.push_str("</gpx>\n");
    s
}
