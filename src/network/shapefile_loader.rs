//! ESRI shapefile loader (crate `shapefile`): Polyline shapes with their dBase
//! attributes, read with the OSM tag names (`highway`, `oneway`, `maxspeed`,
//! …). Coordinates must be geographic WGS-84 (a `.prj` naming a projected
//! system is refused rather than misread).
//!
//! Directed edge exports (OSMnx writes every two-way street twice, `u`→`v` and
//! `v`→`u`) are recognised by their `u`, `v` and `key` fields: the reverse copy
//! of a two-way edge is skipped (`reverse_duplicate`), so a street is one road.

use super::attributes::{DrivableFilter, TagSet};
use super::build::{coordinate_parts, RawRoad};
use super::model::LoadReport;
use crate::error::{Error, Result};
use rustc_hash::FxHashSet;
use shapefile::dbase::FieldValue;
use shapefile::Shape;
use std::path::Path;

const TAG_KEYS: &[&str] = &[
    "highway", "name", "oneway", "junction", "lanes", "width", "maxspeed", "tunnel", "bridge",
    "layer", "area", "covered",
];

/// Reads a shapefile (`.shp` with its `.dbf`, and `.prj` when present).
pub(crate) fn load(
    path: &Path,
    filter: DrivableFilter,
) -> Result<(Vec<RawRoad>, FxHashSet<u64>, LoadReport)> {
    let prj = path.with_extension("prj");
    if let Ok(text) = std::fs::read_to_string(&prj) {
        if text.trim_start().starts_with("PROJCS") {
            return Err(Error::format(
                path,
                "the shapefile uses a projected coordinate system (.prj PROJCS); reproject it to WGS-84 (EPSG:4326)",
            ));
        }
    }
    let mut reader = shapefile::Reader::from_path(path)
        .map_err(|e| Error::format(path, format!("not a readable shapefile: {e}")))?;
    let mut report = LoadReport {
        format: "shapefile".into(),
        ..Default::default()
    };
    let mut roads = Vec::new();
    let mut seen_edges: FxHashSet<(String, String, String, String)> = FxHashSet::default();
    for (index, item) in reader.iter_shapes_and_records().enumerate() {
        let (shape, record) =
            item.map_err(|e| Error::format(path, format!("not a readable shapefile: {e}")))?;
        report.features_read += 1;
        let parts: Vec<Vec<(f64, f64)>> = match shape {
            Shape::Polyline(p) => p
                .parts()
                .iter()
                .map(|r| r.iter().map(|q| (q.x, q.y)).collect())
                .collect(),
            Shape::PolylineM(p) => p
                .parts()
                .iter()
                .map(|r| r.iter().map(|q| (q.x, q.y)).collect())
                .collect(),
            Shape::PolylineZ(p) => p
                .parts()
                .iter()
                .map(|r| r.iter().map(|q| (q.x, q.y)).collect())
                .collect(),
            Shape::NullShape => {
                report.skip("geometry_missing");
                continue;
            }
            other => {
                let name = format!("geometry_{}", other.shapetype()).to_lowercase();
                report.skip(&name);
                continue;
            }
        };
        let text = |k: &str| record.get(k).and_then(field_text);
        let owned: Vec<(&str, String)> = TAG_KEYS
            .iter()
            .filter_map(|&k| text(k).map(|v| (k, v)))
            .collect();
        let mut tags = TagSet::default();
        for (k, v) in &owned {
            tags.set(k, v);
        }
        if let Some(highway) = tags.highway {
            if let Err(r) = filter.check(highway, tags.area) {
                report.skip(r.key());
                continue;
            }
        }
        let id = text("osmid")
            .or_else(|| text("id"))
            .unwrap_or_else(|| format!("record-{index}"));
        // Directed exports: skip the reverse copy of a two-way edge.
        if let (Some(u), Some(v)) = (text("u"), text("v")) {
            if !tags.attributes(String::new()).oneway.is_oneway() {
                let key = text("key").unwrap_or_default();
                let (a, b) = if u <= v { (u, v) } else { (v, u) };
                if !seen_edges.insert((a, b, key, id.clone())) {
                    report.skip("reverse_duplicate");
                    continue;
                }
            }
        }
        let raw_parts = coordinate_parts(path, &format!("record {index}"), parts)?;
        if raw_parts.is_empty() {
            report.skip("degenerate_geometry");
            continue;
        }
        roads.push(RawRoad {
            attributes: tags.attributes(id),
            parts: raw_parts,
            cut: false,
        });
    }
    Ok((roads, FxHashSet::default(), report))
}

/// A dBase value as tag text: numbers without a trailing `.0`, booleans as yes/no.
fn field_text(v: &FieldValue) -> Option<String> {
    let num = |x: f64| {
        if x.fract() == 0.0 && x.abs() < 1e15 {
            format!("{}", x as i64)
        } else {
            x.to_string()
        }
    };
    match v {
        FieldValue::Character(Some(s)) if !s.trim().is_empty() => Some(normalise(s.trim())),
        FieldValue::Memo(s) if !s.trim().is_empty() => Some(normalise(s.trim())),
        FieldValue::Numeric(Some(x)) | FieldValue::Double(x) | FieldValue::Currency(x) => {
            Some(num(*x))
        }
        FieldValue::Float(Some(x)) => Some(num(f64::from(*x))),
        FieldValue::Integer(i) => Some(i.to_string()),
        FieldValue::Logical(Some(b)) => Some(if *b { "yes" } else { "no" }.into()),
        _ => None,
    }
}

/// Python-style booleans (OSMnx writes `True`/`False`) to OSM's yes/no.
fn normalise(s: &str) -> String {
    match s {
        "True" | "true" => "yes".into(),
        "False" | "false" => "no".into(),
        other => other.to_owned(),
    }
}
