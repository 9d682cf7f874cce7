//! Track inputs recognised by content: CSV (TRACK.csv), GPX 1.0/1.1 and
//! GeoJSON.
//!
//! - GPX: every track segment is its own track (`track_id` "N" for track N
//!   when it has one segment, "N.M" for segment M of track N; 1-based). A
//!   point's time is its `<time>`, in seconds since the Unix epoch; points
//!   without one get no time (NaN: the matcher chains them by distance
//!   alone), and identical times are kept (no speed bound between them).
//! - GeoJSON: every LineString, MultiLineString (each line) and MultiPoint
//!   feature is a track, identified by its `track_id`, `id` or `name`
//!   property, else its feature number. Times come from a `coordTimes`,
//!   `times` or `timestamps` property (one per position: RFC 3339 strings or
//!   numbers of seconds), or from a fourth coordinate; else none.
//! - A time earlier than the one before it in the same track is an error,
//!   as is one beyond ±[`MAX_ABS_TIME_S`] (1e11 s).
//!
//! For GPX and GeoJSON, a row's `line` is the point's number in the file
//! (1-based, counting every track point in order).

use super::track::{read_text, read_track_text, time_beyond_limit, TrackRow};
use crate::error::{Error, Result};
use std::path::Path;

/// The kinds of track file.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TrackFormat {
    /// TRACK.csv.
    Csv,
    /// GPX.
    Gpx,
    /// GeoJSON.
    GeoJson,
}

impl TrackFormat {
    /// The format's name.
    pub fn as_str(self) -> &'static str {
        match self {
            TrackFormat::Csv => "csv",
            TrackFormat::Gpx => "gpx",
            TrackFormat::GeoJson => "geojson",
        }
    }
}

/// The format of a track file's text, by its first non-blank character.
pub fn sniff(text: &str) -> TrackFormat {
    match text.trim_start().chars().next() {
        Some('<') => TrackFormat::Gpx,
        Some('{') => TrackFormat::GeoJson,
        _ => TrackFormat::Csv,
    }
}

/// The format of a track file, by its first non-blank character (read
/// without reading the whole file).
pub fn sniff_file(path: &Path) -> Result<TrackFormat> {
    use std::io::Read;
    let mut f = std::fs::File::open(path).map_err(|e| Error::io(path, e))?;
    let mut buf = [0u8; 4096];
    loop {
        let n = f.read(&mut buf).map_err(|e| Error::io(path, e))?;
        if n == 0 {
            return Ok(TrackFormat::Csv);
        }
        // Blanks and a byte-order mark's bytes come before the content.
        if let Some(&b) = buf[..n]
            .iter()
            .find(|b| !b.is_ascii_whitespace() && ![0xef, 0xbb, 0xbf].contains(*b))
        {
            return Ok(match b {
                b'<' => TrackFormat::Gpx,
                b'{' => TrackFormat::GeoJson,
                _ => TrackFormat::Csv,
            });
        }
    }
}

pub use super::track::{MAX_ABS_TIME_S, WHOLE_FILE_LIMIT_BYTES};

/// Reads a track file of any supported format.
pub fn read_track_file(path: &Path) -> Result<(Vec<TrackRow>, TrackFormat)> {
    let len = std::fs::metadata(path)
        .map_err(|e| Error::io(path, e))?
        .len();
    if len > WHOLE_FILE_LIMIT_BYTES {
        return Err(Error::format(
            path,
            format!(
                "{} MB: over the {} MB limit of a track read whole (GPX, GeoJSON, or a CSV interleaving its tracks); write it as a CSV with each track's rows together to stream it",
                len >> 20,
                WHOLE_FILE_LIMIT_BYTES >> 20
            ),
        ));
    }
    let text = read_text(path, "track")?;
    let format = sniff(&text);
    let rows = match format {
        TrackFormat::Csv => read_track_text(path, &text)?,
        TrackFormat::Gpx => read_gpx(path, &text)?,
        TrackFormat::GeoJson => read_geojson(path, &text)?,
    };
    Ok((rows, format))
}

/// Builds rows from tracks of (id, points (lat, lon, time)), checking
/// coordinates and time order.
/// A track read: its identifier and points (latitude, longitude, time).
type RawTrack = (String, Vec<(f64, f64, f64)>);

fn rows_of(path: &Path, tracks: Vec<RawTrack>) -> Result<Vec<TrackRow>> {
    let mut rows = Vec::new();
    let mut number = 0usize;
    for (id, pts) in tracks {
        let mut last: Option<(f64, usize)> = None;
        for (lat, lon, t) in pts {
            number += 1;
            if !(lat.is_finite()
                && lon.is_finite()
                && (-90.0..=90.0).contains(&lat)
                && (-180.0..=180.0).contains(&lon))
            {
                return Err(Error::format(
                    path,
                    format!("track {id}, point {number}: coordinate out of range (lat {lat}, lon {lon})"),
                ));
            }
            if t.is_finite() {
                if t.abs() > MAX_ABS_TIME_S {
                    return Err(Error::format(
                        path,
                        format!(
                            "track {id}, point {number}: {}",
                            time_beyond_limit(&format!("time {t} s"))
                        ),
                    ));
                }
                if let Some((prev, pn)) = last {
                    if t < prev {
                        return Err(Error::format(
                            path,
                            format!(
                                "track {id}, point {number}: time goes back ({} s before point {pn})",
                                prev - t
                            ),
                        ));
                    }
                }
                last = Some((t, number));
            }
            rows.push(TrackRow {
                line: number,
                track_id: id.clone(),
                t_s: t,
                lat,
                lon,
                heading_deg: None,
                speed_mps: None,
            });
        }
    }
    Ok(rows)
}

/// Reads a GPX file's track points.
pub fn read_gpx(path: &Path, text: &str) -> Result<Vec<TrackRow>> {
    // Empty text elements (`<name/>`, `<desc></desc>`: real exports have
    // them, e.g. gpx.py's) carry nothing, but the `gpx` crate rejects them.
    let mut cleaned = std::borrow::Cow::Borrowed(text);
    for tag in ["name", "desc", "type", "cmt", "src", "sym", "keywords"] {
        for empty in [
            format!("<{tag}/>"),
            format!("<{tag} />"),
            format!("<{tag}></{tag}>"),
        ] {
            if cleaned.contains(&empty) {
                cleaned = cleaned.replace(&empty, "").into();
            }
        }
    }
    let gpx = gpx::read(cleaned.as_bytes())
        .map_err(|e| Error::format(path, format!("not a readable GPX file ({e})")))?;
    let mut tracks = Vec::new();
    for (i, trk) in gpx.tracks.iter().enumerate() {
        let n = trk.segments.len();
        for (j, seg) in trk.segments.iter().enumerate() {
            if seg.points.is_empty() {
                continue;
            }
            let id = if n == 1 {
                format!("{}", i + 1)
            } else {
                format!("{}.{}", i + 1, j + 1)
            };
            let pts = seg
                .points
                .iter()
                .map(|w| {
                    let p = w.point();
                    let t = w.time.map_or(f64::NAN, |t| {
                        let t: time::OffsetDateTime = t.into();
                        t.unix_timestamp_nanos() as f64 * 1e-9
                    });
                    (p.y(), p.x(), t)
                })
                .collect();
            tracks.push((id, pts));
        }
    }
    if tracks.is_empty() {
        return Err(Error::format(
            path,
            format!(
                "no track points in this GPX file (it has {} track(s) with no <trkpt>, {} waypoint(s), {} route(s); matching needs <trk><trkseg><trkpt>)",
                gpx.tracks.len(),
                gpx.waypoints.len(),
                gpx.routes.len()
            ),
        ));
    }
    rows_of(path, tracks)
}

fn time_of(v: &serde_json::Value) -> Option<f64> {
    match v {
        serde_json::Value::Number(n) => n.as_f64(),
        serde_json::Value::String(s) => {
            time::OffsetDateTime::parse(s, &time::format_description::well_known::Rfc3339)
                .ok()
                .map(|t| t.unix_timestamp_nanos() as f64 * 1e-9)
                .or_else(|| s.parse().ok())
        }
        _ => None,
    }
}

/// Reads a GeoJSON file's LineString, MultiLineString and MultiPoint features.
pub fn read_geojson(path: &Path, text: &str) -> Result<Vec<TrackRow>> {
    use geojson::{GeoJson, Value};
    let gj: GeoJson = text
        .parse()
        .map_err(|e| Error::format(path, format!("not readable as GeoJSON ({e})")))?;
    let features = match gj {
        GeoJson::FeatureCollection(fc) => fc.features,
        GeoJson::Feature(f) => vec![f],
        GeoJson::Geometry(g) => vec![geojson::Feature {
            geometry: Some(g),
            ..Default::default()
        }],
    };
    let mut tracks = Vec::new();
    for (k, f) in features.iter().enumerate() {
        let Some(g) = &f.geometry else { continue };
        let lines: Vec<&Vec<Vec<f64>>> = match &g.value {
            Value::LineString(c) | Value::MultiPoint(c) => vec![c],
            Value::MultiLineString(ls) => ls.iter().collect(),
            _ => continue,
        };
        let prop = |name: &str| f.properties.as_ref().and_then(|p| p.get(name));
        let base = ["track_id", "id", "name"]
            .iter()
            .find_map(|n| match prop(n) {
                Some(serde_json::Value::String(s)) => Some(s.clone()),
                Some(serde_json::Value::Number(x)) => Some(x.to_string()),
                _ => None,
            })
            .or_else(|| {
                f.id.as_ref().map(|id| match id {
                    geojson::feature::Id::String(s) => s.clone(),
                    geojson::feature::Id::Number(n) => n.to_string(),
                })
            })
            .unwrap_or_else(|| (k + 1).to_string());
        let times: Option<&Vec<serde_json::Value>> = ["coordTimes", "times", "timestamps"]
            .iter()
            .find_map(|n| prop(n).and_then(|v| v.as_array()));
        let mut offset = 0usize;
        for (j, coords) in lines.iter().enumerate() {
            let id = if lines.len() == 1 {
                base.clone()
            } else {
                format!("{base}.{}", j + 1)
            };
            // coordTimes of a MultiLineString: an array per line.
            let line_times: Option<Vec<serde_json::Value>> = times.map(|t| {
                if lines.len() > 1 && t.first().is_some_and(|x| x.is_array()) {
                    t.get(j)
                        .and_then(|x| x.as_array())
                        .cloned()
                        .unwrap_or_default()
                } else {
                    t.iter().skip(offset).take(coords.len()).cloned().collect()
                }
            });
            offset += coords.len();
            let mut pts = Vec::with_capacity(coords.len());
            for (i, c) in coords.iter().enumerate() {
                let given = line_times
                    .as_ref()
                    .and_then(|ts| ts.get(i))
                    .filter(|v| !v.is_null());
                let t = match given {
                    // A time that is there but unreadable is an error, not
                    // a point without a time.
                    Some(v) => match time_of(v).filter(|t| t.is_finite()) {
                        Some(t) => t,
                        None => {
                            return Err(Error::format(
                                path,
                                format!(
                                    "track {id}, point {}: time {v} is neither an RFC 3339 \
                                     time nor a finite number of seconds",
                                    i + 1
                                ),
                            ))
                        }
                    },
                    None => c.get(3).copied().unwrap_or(f64::NAN),
                };
                pts.push((c[1], c[0], t));
            }
            tracks.push((id, pts));
        }
    }
    if tracks.iter().all(|(_, p): &(String, Vec<_>)| p.is_empty()) {
        return Err(Error::format(
            path,
            format!(
                "no LineString, MultiLineString or MultiPoint feature to match ({} feature(s) of other kinds)",
                features.len()
            ),
        ));
    }
    rows_of(path, tracks)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn formats_are_recognised_by_content() {
        assert_eq!(sniff("\n  <?xml version"), TrackFormat::Gpx);
        assert_eq!(sniff(" {\"type\""), TrackFormat::GeoJson);
        assert_eq!(sniff("t_s,lat,lon"), TrackFormat::Csv);
    }

    #[test]
    fn gpx_segments_times_and_errors() {
        let p = Path::new("t.gpx");
        let gpx = |body: &str| {
            format!(
                "<?xml version=\"1.0\"?><gpx version=\"1.1\" creator=\"t\" xmlns=\"http://www.topografix.com/GPX/1/1\">{body}</gpx>"
            )
        };
        let pt = |lat: f64, t: Option<&str>| match t {
            Some(t) => format!("<trkpt lat=\"{lat}\" lon=\"24.9\"><time>{t}</time></trkpt>"),
            None => format!("<trkpt lat=\"{lat}\" lon=\"24.9\"></trkpt>"),
        };
        let text = gpx(&format!(
            "<trk><name/><desc></desc><trkseg>{}{}</trkseg><trkseg>{}{}</trkseg></trk><trk><trkseg>{}</trkseg></trk>",
            pt(60.1, Some("2020-01-01T00:00:00Z")),
            pt(60.2, Some("2020-01-01T00:00:00Z")),
            pt(60.3, None),
            pt(60.4, Some("2020-01-01T00:01:00Z")),
            pt(60.5, None),
        ));
        let rows = read_gpx(p, &text).unwrap();
        let ids: Vec<&str> = rows.iter().map(|r| r.track_id.as_str()).collect();
        assert_eq!(ids, ["1.1", "1.1", "1.2", "1.2", "2"]);
        assert_eq!(rows[0].t_s, 1_577_836_800.0);
        assert_eq!(rows[1].t_s, rows[0].t_s);
        assert!(rows[2].t_s.is_nan());
        assert_eq!(rows[3].t_s, 1_577_836_860.0);
        assert_eq!(rows[4].line, 5);
        assert_eq!((rows[4].lat, rows[4].lon), (60.5, 24.9));
        let back = gpx(&format!(
            "<trk><trkseg>{}{}</trkseg></trk>",
            pt(60.1, Some("2020-01-01T00:01:00Z")),
            pt(60.2, Some("2020-01-01T00:00:00Z"))
        ));
        let e = read_gpx(p, &back).unwrap_err().to_string();
        assert!(
            e.contains("t.gpx") && e.contains("point 2: time goes back (60 s"),
            "{e}"
        );
        let e = read_gpx(p, &gpx("<wpt lat=\"60\" lon=\"24\"></wpt>"))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("no track points") && e.contains("1 waypoint"),
            "{e}"
        );
        let e = read_gpx(p, "<gpx><trk>").unwrap_err().to_string();
        assert!(e.contains("not a readable GPX file"), "{e}");
    }

    #[test]
    fn geojson_lines_points_and_times() {
        let p = Path::new("t.geojson");
        let text = r#"{"type":"FeatureCollection","features":[
          {"type":"Feature","properties":{"name":"a","coordTimes":["2020-01-01T00:00:00Z","2020-01-01T00:00:10Z"]},
           "geometry":{"type":"LineString","coordinates":[[24.9,60.1],[24.9,60.2]]}},
          {"type":"Feature","properties":{},
           "geometry":{"type":"MultiPoint","coordinates":[[24.9,60.3,0,5],[24.9,60.4]]}},
          {"type":"Feature","properties":{},"geometry":{"type":"Point","coordinates":[24.9,60.3]}}]}"#;
        let rows = read_geojson(p, text).unwrap();
        let ids: Vec<&str> = rows.iter().map(|r| r.track_id.as_str()).collect();
        assert_eq!(ids, ["a", "a", "2", "2"]);
        assert_eq!(
            (rows[0].t_s, rows[1].t_s, rows[2].t_s),
            (1_577_836_800.0, 1_577_836_810.0, 5.0)
        );
        assert!(rows[3].t_s.is_nan());
        let e = read_geojson(
            p,
            r#"{"type":"Feature","properties":{},"geometry":{"type":"Point","coordinates":[1,2]}}"#,
        )
        .unwrap_err()
        .to_string();
        assert!(
            e.contains("t.geojson") && e.contains("no LineString"),
            "{e}"
        );
    }
}
