//! OpenStreetMap XML (`.osm`) loader, streaming with `quick-xml`.

use super::attributes::{DrivableFilter, TagSet};
use super::build::RawRoad;
use super::model::LoadReport;
use super::osm_common::{assemble_ways, OsmWay};
use crate::error::{Error, Result};
use quick_xml::events::{BytesStart, Event};
use quick_xml::Reader;
use rustc_hash::FxHashSet;
use std::path::Path;

struct WayBuilder {
    id: i64,
    refs: Vec<i64>,
    tags: Vec<(String, String)>,
}

/// Reads an OSM XML document held in memory.
pub(crate) fn load(
    path: &Path,
    bytes: &[u8],
    filter: DrivableFilter,
) -> Result<(Vec<RawRoad>, FxHashSet<u64>, LoadReport)> {
    let mut reader = Reader::from_reader(bytes);
    reader.config_mut().trim_text(true);
    let mut report = LoadReport {
        format: "osm_xml".into(),
        ..Default::default()
    };
    let mut nodes: Vec<(i64, f64, f64)> = Vec::new();
    let mut ways: Vec<OsmWay> = Vec::new();
    let mut way: Option<WayBuilder> = None;
    let mut saw_osm = false;
    let mut buf = Vec::new();
    loop {
        let pos = reader.buffer_position();
        let event = reader
            .read_event_into(&mut buf)
            .map_err(|e| Error::format(path, format!("invalid OSM XML at byte {pos}: {e}")))?;
        match event {
            Event::Start(e) | Event::Empty(e) => match e.name().as_ref() {
                b"osm" => saw_osm = true,
                b"node" => {
                    let id = int_attr(path, &e, b"id")?;
                    let lat = float_attr(path, &e, b"lat")?;
                    let lon = float_attr(path, &e, b"lon")?;
                    nodes.push((id, lat, lon));
                }
                b"way" => {
                    way = Some(WayBuilder {
                        id: int_attr(path, &e, b"id")?,
                        refs: Vec::new(),
                        tags: Vec::new(),
                    });
                }
                b"nd" => {
                    if let Some(w) = way.as_mut() {
                        w.refs.push(int_attr(path, &e, b"ref")?);
                    }
                }
                b"tag" => {
                    if let Some(w) = way.as_mut() {
                        let k = str_attr(path, &e, b"k")?;
                        let v = str_attr(path, &e, b"v")?;
                        w.tags.push((k, v));
                    }
                }
                _ => {}
            },
            Event::End(e) if e.name().as_ref() == b"way" => {
                if let Some(w) = way.take() {
                    finish_way(w, filter, &mut ways, &mut report);
                }
            }
            Event::Eof => break,
            _ => {}
        }
        buf.clear();
    }
    if !saw_osm {
        return Err(Error::format(
            path,
            "not an OSM XML document: no <osm> element",
        ));
    }
    if way.is_some() {
        return Err(Error::format(
            path,
            "invalid OSM XML: the document ends inside a <way>",
        ));
    }
    nodes.sort_unstable_by_key(|n| n.0);
    assemble_ways(path, &nodes, ways, report)
}

fn finish_way(
    w: WayBuilder,
    filter: DrivableFilter,
    ways: &mut Vec<OsmWay>,
    report: &mut LoadReport,
) {
    let mut tags = TagSet::default();
    for (k, v) in &w.tags {
        tags.set(k, v);
    }
    let Some(highway) = tags.highway else {
        return;
    };
    report.features_read += 1;
    if let Err(r) = filter.check(highway, tags.area) {
        report.skip(r.key());
        return;
    }
    ways.push(OsmWay {
        attributes: tags.attributes(w.id.to_string()),
        refs: w.refs,
    });
}

fn str_attr(path: &Path, e: &BytesStart, name: &[u8]) -> Result<String> {
    let element = String::from_utf8_lossy(e.name().as_ref()).into_owned();
    let attr = e
        .try_get_attribute(name)
        .map_err(|err| Error::format(path, format!("invalid OSM XML in <{element}>: {err}")))?
        .ok_or_else(|| {
            Error::format(
                path,
                format!(
                    "invalid OSM XML: <{element}> without attribute '{}'",
                    String::from_utf8_lossy(name)
                ),
            )
        })?;
    attr.unescape_value()
        .map(|v| v.into_owned())
        .map_err(|err| Error::format(path, format!("invalid OSM XML in <{element}>: {err}")))
}

fn int_attr(path: &Path, e: &BytesStart, name: &[u8]) -> Result<i64> {
    let s = str_attr(path, e, name)?;
    s.trim().parse().map_err(|_| {
        Error::format(
            path,
            format!(
                "invalid OSM XML: attribute {}=\"{s}\" is not an integer",
                String::from_utf8_lossy(name)
            ),
        )
    })
}

fn float_attr(path: &Path, e: &BytesStart, name: &[u8]) -> Result<f64> {
    let s = str_attr(path, e, name)?;
    s.trim().parse().map_err(|_| {
        Error::format(
            path,
            format!(
                "invalid OSM XML: attribute {}=\"{s}\" is not a number",
                String::from_utf8_lossy(name)
            ),
        )
    })
}
