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

/// The `.prj` beside `path`, when present: it must be text, and a projected
/// system (`PROJCS`) is refused rather than misread as degrees.
fn check_prj(path: &Path) -> Result<()> {
    let prj = path.with_extension("prj");
    if !prj.exists() {
        return Ok(());
    }
    let bytes = crate::fsio::read_limited(&prj, 1 << 20, "projection file (.prj)")?;
    let text = String::from_utf8(bytes).map_err(|_| {
        Error::format(
            &prj,
            "the projection file (.prj) is not text: expected a WKT coordinate system such as GEOGCS[\"GCS_WGS_1984\", ...]",
        )
    })?;
    if text.trim_start().starts_with("PROJCS") {
        return Err(Error::format(
            &prj,
            format!(
                "{} uses a projected coordinate system (PROJCS); reproject it to WGS-84 (EPSG:4326)",
                file_name(path)
            ),
        ));
    }
    Ok(())
}

fn file_name(path: &Path) -> String {
    path.file_name().map_or_else(
        || path.display().to_string(),
        |n| n.to_string_lossy().into_owned(),
    )
}

type FileReader<'a> =
    shapefile::Reader<std::io::Cursor<&'a [u8]>, std::io::BufReader<std::fs::File>>;

/// Opens the `.shp` (its bytes `shp`, read once by the caller and read here
/// in sequence: the `.shx` index is not needed) and its `.dbf`, each error
/// naming the component that fails.
fn open<'a>(path: &Path, shp: &'a [u8]) -> Result<FileReader<'a>> {
    use std::io::BufReader;
    let shapes = shapefile::ShapeReader::new(std::io::Cursor::new(shp))
        .map_err(|e| Error::format(path, format!("the shape file (.shp) {}", shp_problem(&e))))?;
    let dbf = path.with_extension("dbf");
    let f = std::fs::File::open(&dbf).map_err(|e| {
        if e.kind() == std::io::ErrorKind::NotFound {
            Error::format(
                &dbf,
                format!(
                    "missing: the shapefile {} keeps its road attributes in this .dbf file beside it",
                    file_name(path)
                ),
            )
        } else {
            Error::io(&dbf, e)
        }
    })?;
    let table = shapefile::dbase::Reader::new(BufReader::new(f)).map_err(|e| {
        Error::format(
            &dbf,
            format!("the attribute table (.dbf) {}", dbf_problem(&e)),
        )
    })?;
    Ok(shapefile::Reader::new(shapes, table))
}

/// Checks the `.shp`'s records against its size before the shapefile crate
/// reads them: a record that declares more parts or points than its bytes
/// hold, or parts that do not start in ascending order within its points,
/// would make the reader reserve memory for them (gigabytes for a corrupt
/// count, found by fuzzing) before failing. `bytes` is the `.shp`.
fn check_shp_records(path: &Path, bytes: &[u8]) -> Result<()> {
    let corrupt = |at: usize, what: String| {
        Error::format(
            path,
            format!("the shape file (.shp) at record {at}: {what} (corrupt)"),
        )
    };
    let be = |i: usize| {
        bytes
            .get(i..i + 4)
            .map(|b| i32::from_be_bytes(b.try_into().unwrap()))
    };
    let le = |i: usize| {
        bytes
            .get(i..i + 4)
            .map(|b| i32::from_le_bytes(b.try_into().unwrap()))
    };
    let mut at = 100; // after the file header
    let mut index = 0;
    while at + 8 <= bytes.len() {
        index += 1;
        let words = be(at + 4).unwrap_or(0);
        let len = 2 * words.max(0) as usize;
        let content = at + 8;
        if words < 0 || content + len > bytes.len() {
            return Err(corrupt(
                index,
                format!(
                    "declares {len} bytes of content where {} remain",
                    bytes.len() - content
                ),
            ));
        }
        // Poly-lines and polygons (plain, M, Z) and multi-patches: parts
        // and points after the shape type and the 32-byte box; each part
        // takes at least 4 bytes, each point at least 16 (x, y).
        if let Some(3 | 5 | 13 | 15 | 23 | 25 | 31) = le(content) {
            if let (Some(parts), Some(points)) = (le(content + 36), le(content + 40)) {
                let need = 44 + 4 * parts.max(0) as u64 + 16 * points.max(0) as u64;
                if parts < 0 || points < 0 || need > len as u64 {
                    return Err(corrupt(
                        index,
                        format!(
                            "declares {parts} part(s) and {points} point(s), more than its {len} bytes hold"
                        ),
                    ));
                }
                // Each part starts at an index into the record's points, in
                // ascending order: the reader sizes a part as the next start
                // minus its own, so an index out of order or beyond the points
                // made it reserve gigabytes (found by fuzzing).
                let mut previous = 0;
                for k in 0..parts as usize {
                    let start = le(content + 44 + 4 * k).unwrap_or(-1);
                    if start < previous || start > points {
                        return Err(corrupt(
                            index,
                            format!(
                                "part {} starts at point {start}, outside 0..={points} or before \
                                 the part before it",
                                k + 1
                            ),
                        ));
                    }
                    previous = start;
                }
            }
        }
        at = content + len;
    }
    Ok(())
}

/// A failure while reading record `index`, named by its component.
fn component_error(path: &Path, index: usize, e: shapefile::Error) -> Error {
    match e {
        shapefile::Error::DbaseError(d) => Error::format(
            &path.with_extension("dbf"),
            format!(
                "the attribute table (.dbf) is unreadable at record {}: {}",
                index + 1,
                dbf_problem(&d)
            ),
        ),
        e => Error::format(
            path,
            format!(
                "the shape file (.shp) at record {}: {}",
                index + 1,
                shp_problem(&e)
            ),
        ),
    }
}

/// What is wrong with a `.shp`, in words.
fn shp_problem(e: &shapefile::Error) -> String {
    use shapefile::Error as E;
    match e {
        E::IoError(io) if io.kind() == std::io::ErrorKind::UnexpectedEof => {
            "ends too early: the file is truncated".into()
        }
        E::IoError(io) => format!("cannot be read: {io}"),
        E::InvalidFileCode(c) => format!("is not a shapefile (file code {c}, expected 9994)"),
        E::InvalidShapeType(c) => format!("holds an unknown shape type code {c}"),
        E::InvalidShapeRecordSize => {
            "declares a record size that does not match its content (corrupt)".into()
        }
        E::AllocationLimitExceeded { requested_bytes } => {
            format!("declares a shape of {requested_bytes} bytes, more than it can hold (corrupt)")
        }
        E::MismatchShapeType { requested, actual } => {
            format!("mixes shape types ({actual} where the header says {requested})")
        }
        other => format!("is invalid: {other}"),
    }
}

/// What is wrong with a `.dbf`, in words.
fn dbf_problem(e: &shapefile::dbase::Error) -> String {
    use shapefile::dbase::ErrorKind as K;
    let what = match e.kind() {
        K::IoError(io) if io.kind() == std::io::ErrorKind::UnexpectedEof => {
            "ends too early: the file is truncated".to_string()
        }
        K::IoError(io) => format!("cannot be read: {io}"),
        K::InvalidFieldType(c) => format!("declares a field of unknown type '{c}'"),
        K::ParseFloatError(_) | K::ParseIntError(_) => "holds a number that is not a number".into(),
        K::StringDecodeError(_) => "holds text that is not valid in its encoding".into(),
        K::InvalidFile(d) => format!("is not a valid dBase table: {d}"),
        other => other.to_string(),
    };
    match e.field_index() {
        Some(i) => format!("{what} (field {})", i.0 + 1),
        None => what,
    }
}

/// Reads a shapefile: the `.shp` at `path` (its bytes `shp`, as read by
/// the map reader) with its `.dbf`, and `.prj` when present.
pub(crate) fn load(
    path: &Path,
    shp: &[u8],
    filter: DrivableFilter,
) -> Result<(Vec<RawRoad>, FxHashSet<u64>, LoadReport)> {
    check_prj(path)?;
    check_shp_records(path, shp)?;
    let mut reader = open(path, shp)?;
    let mut report = LoadReport {
        format: "shapefile".into(),
        ..Default::default()
    };
    let mut roads = Vec::new();
    let mut seen_edges: FxHashSet<(String, String, String, String)> = FxHashSet::default();
    for (index, item) in reader.iter_shapes_and_records().enumerate() {
        let (shape, record) = item.map_err(|e| component_error(path, index, e))?;
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
