//! GeoJSON loader (crate `geojson`): LineString and MultiLineString features of a
//! FeatureCollection become roads; their properties are read with the OSM tag
//! names (`highway`, `oneway`, `lanes`, …). Other geometries are skipped and
//! counted. Vertices are identified by their coordinates (1e-7 degree), so
//! features meeting at the same point are connected.

use super::attributes::{DrivableFilter, TagSet};
use super::build::{coordinate_parts, RawRoad};
use super::model::LoadReport;
use crate::error::{Error, Result};
use geojson::{feature::Id, GeoJson, JsonObject, JsonValue};
use rustc_hash::FxHashSet;
use std::path::Path;

const TAG_KEYS: &[&str] = &[
    "highway", "name", "oneway", "junction", "lanes", "width", "maxspeed", "tunnel", "bridge",
    "layer", "area", "covered",
];

/// Reads a GeoJSON FeatureCollection held in memory.
pub(crate) fn load(
    path: &Path,
    bytes: &[u8],
    filter: DrivableFilter,
) -> Result<(Vec<RawRoad>, FxHashSet<u64>, LoadReport)> {
    let value: JsonValue = serde_json::from_slice(bytes)
        .map_err(|e| Error::format(path, format!("invalid JSON: {e}")))?;
    let kind = value
        .get("type")
        .and_then(JsonValue::as_str)
        .map(str::to_owned);
    let geojson = GeoJson::from_json_value(value)
        .map_err(|e| Error::format(path, format!("invalid GeoJSON: {e}")))?;
    let GeoJson::FeatureCollection(collection) = geojson else {
        return Err(Error::format(
            path,
            format!(
                "GeoJSON is a {}, not a FeatureCollection",
                kind.as_deref().unwrap_or("object without a type")
            ),
        ));
    };

    let mut report = LoadReport {
        format: "geojson".into(),
        ..Default::default()
    };
    let mut roads = Vec::new();
    for (index, feature) in collection.features.into_iter().enumerate() {
        report.features_read += 1;
        let id = match (
            &feature.id,
            feature.properties.as_ref().and_then(|p| p.get("id")),
        ) {
            (Some(Id::String(s)), _) => s.clone(),
            (Some(Id::Number(n)), _) => n.to_string(),
            (None, Some(v)) => value_text(v).unwrap_or_else(|| format!("feature-{index}")),
            (None, None) => format!("feature-{index}"),
        };
        let lines: Vec<Vec<Vec<f64>>> = match feature.geometry.map(|g| g.value) {
            Some(geojson::Value::LineString(l)) => vec![l],
            Some(geojson::Value::MultiLineString(m)) => m,
            Some(other) => {
                report.skip(&format!("geometry_{}", geometry_name(&other)));
                continue;
            }
            None => {
                report.skip("geometry_missing");
                continue;
            }
        };
        let owned = properties_as_text(feature.properties.as_ref());
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
        let mut runs = Vec::with_capacity(lines.len());
        for line in lines {
            let mut run = Vec::with_capacity(line.len());
            for pos in line {
                if pos.len() < 2 {
                    return Err(Error::format(
                        path,
                        format!("feature {id}: a position has fewer than two numbers"),
                    ));
                }
                run.push((pos[0], pos[1]));
            }
            runs.push(run);
        }
        let parts = coordinate_parts(path, &format!("feature {id}"), runs)?;
        if parts.is_empty() {
            report.skip("degenerate_geometry");
            continue;
        }
        roads.push(RawRoad {
            attributes: tags.attributes(id),
            parts,
            cut: false,
        });
    }
    Ok((roads, FxHashSet::default(), report))
}

fn geometry_name(v: &geojson::Value) -> &'static str {
    match v {
        geojson::Value::Point(_) => "point",
        geojson::Value::MultiPoint(_) => "multipoint",
        geojson::Value::LineString(_) => "linestring",
        geojson::Value::MultiLineString(_) => "multilinestring",
        geojson::Value::Polygon(_) => "polygon",
        geojson::Value::MultiPolygon(_) => "multipolygon",
        geojson::Value::GeometryCollection(_) => "geometrycollection",
    }
}

fn value_text(v: &JsonValue) -> Option<String> {
    match v {
        JsonValue::String(s) => Some(s.clone()),
        JsonValue::Number(n) => Some(n.to_string()),
        JsonValue::Bool(b) => Some(if *b { "yes" } else { "no" }.to_owned()),
        _ => None,
    }
}

fn properties_as_text(props: Option<&JsonObject>) -> Vec<(&'static str, String)> {
    let Some(props) = props else {
        return Vec::new();
    };
    TAG_KEYS
        .iter()
        .filter_map(|&k| props.get(k).and_then(value_text).map(|v| (k, v)))
        .collect()
}
