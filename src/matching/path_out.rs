//! The complete path written out: PATH.csv (one row per stretch of road, in
//! driving order) and a GeoJSON of LineStrings (one per continuous piece,
//! with its roads).

use super::cpath::PathStep;
use super::evaluate::RoadLengths;
use super::track::push_csv_field;
use crate::decimal::push_fixed;
use crate::network::Network;
use std::fmt::Write as _;

/// PATH.csv text for tracks of (track id, path):
/// `track_id,seq,road_id,from_offset_m,to_offset_m,length_m`, `seq`
/// counting the stretches of each track from 0 in driving order, offsets
/// along the road from its start.
pub fn path_csv(net: &Network, tracks: &[(&str, &[PathStep])]) -> String {
    let mut s = String::from("track_id,seq,road_id,from_offset_m,to_offset_m,length_m\n");
    for (id, path) in tracks {
        for (k, p) in path.iter().enumerate() {
            push_csv_field(&mut s, id);
            let _ = write!(s, ",{k},");
            push_csv_field(&mut s, &net.roads[p.road as usize].attributes.id);
            for x in [p.from_offset_m, p.to_offset_m, p.length_m()] {
                s.push(',');
                push_fixed(&mut s, x, 2);
            }
            s.push('\n');
        }
    }
    s
}

/// Length driven by road identifier along the paths.
pub fn path_lengths(net: &Network, paths: &[&[PathStep]]) -> RoadLengths {
    let mut out = RoadLengths::new();
    for path in paths {
        for p in *path {
            *out.entry(net.roads[p.road as usize].attributes.id.clone())
                .or_default() += p.length_m();
        }
    }
    out
}

/// GeoJSON text: a FeatureCollection with a LineString per continuous
/// piece of each track (properties `track_id`, `piece`, `length_m` and
/// `roads`, the road identifiers in driving order).
pub fn path_geojson(net: &Network, tracks: &[(&str, &[PathStep])]) -> String {
    use geojson::{Feature, FeatureCollection, Geometry, JsonObject, Value};
    let mut features = Vec::new();
    for (id, path) in tracks {
        let mut k = 0;
        while k < path.len() {
            let piece = path[k].piece;
            let end = k + path[k..].iter().take_while(|p| p.piece == piece).count();
            let mut coords: Vec<Vec<f64>> = Vec::new();
            let mut roads: Vec<serde_json::Value> = Vec::new();
            let mut length = 0.0;
            for p in &path[k..end] {
                roads.push(net.roads[p.road as usize].attributes.id.clone().into());
                length += p.length_m();
                for &(sec, from, to) in &p.sections {
                    for q in crate::route::section_points(net, sec, from, to) {
                        let g = net.frame.to_geodetic([q[0], q[1], 0.0]);
                        let c = vec![
                            (g.lon_deg() * 1e7).round() / 1e7,
                            (g.lat_deg() * 1e7).round() / 1e7,
                        ];
                        if coords.last() != Some(&c) {
                            coords.push(c);
                        }
                    }
                }
            }
            if coords.len() == 1 {
                coords.push(coords[0].clone());
            }
            let mut props = JsonObject::new();
            props.insert("track_id".into(), (*id).into());
            props.insert("piece".into(), piece.into());
            props.insert(
                "length_m".into(),
                ((length * 100.0_f64).round() / 100.0).into(),
            );
            props.insert("roads".into(), roads.into());
            features.push(Feature {
                geometry: Some(Geometry::new(Value::LineString(coords))),
                properties: Some(props),
                ..Default::default()
            });
            k = end;
        }
    }
    FeatureCollection {
        features,
        bbox: None,
        foreign_members: None,
    }
    .to_string()
}
