//! The contents of output files: tag files for installers (CSV, GeoJSON, KML,
//! GPX), a plan's profile and the network defects. Files are written with
//! [`write_atomic`] (from [`crate::fsio`], re-exported here), so each appears
//! completely or not at all.

mod tags;

pub use crate::fsio::write_atomic;
pub use crate::tags::{ExportMetadata, TagRecord};
pub use tags::{
    csv_row, heights_source, tags_csv, tags_geojson, tags_gpx, tags_kml, tags_meta_json,
    CSV_COLUMNS, GPX_NAMESPACE,
};

/// The defects as a GeoJSON FeatureCollection of points (RFC 7946, [lon, lat]).
pub fn defects_geojson(defects: &crate::network::DefectReport) -> String {
    let features = defects
        .items
        .iter()
        .map(|d| {
            let mut properties = geojson::JsonObject::new();
            properties.insert("kind".to_owned(), d.kind.into());
            properties.insert("roads".to_owned(), d.roads.clone().into());
            properties.insert("detail".to_owned(), d.detail.clone().into());
            geojson::Feature {
                bbox: None,
                geometry: Some(geojson::Geometry::new(geojson::Value::Point(vec![
                    d.lat_lon[1],
                    d.lat_lon[0],
                ]))),
                id: None,
                properties: Some(properties),
                foreign_members: None,
            }
        })
        .collect();
    let fc = geojson::FeatureCollection {
        bbox: None,
        features,
        foreign_members: None,
    };
    serde_json::to_string_pretty(&fc).unwrap_or_default()
}

/// The header of a plan's `profile.csv`.
pub const PLAN_PROFILE_HEADER: &str = "t_s,distance_m,bound95_with_tags_m,bound95_without_tags_m";

/// A plan's `profile.csv`: the predicted 95 % horizontal bound along the
/// route with the plan's tags (all read) and with none, at the points of the
/// with-tags profile (the without-tags bound taken at the same time).
pub fn plan_profile_csv(
    with_tags: &[crate::planner::budget::BudgetPoint],
    without_tags: &[crate::planner::budget::BudgetPoint],
) -> String {
    use std::fmt::Write as _;
    let mut s = String::with_capacity(48 * (with_tags.len() + 1));
    s.push_str(PLAN_PROFILE_HEADER);
    s.push('\n');
    for p in with_tags {
        let without = if without_tags.is_empty() {
            f64::NAN
        } else {
            let i = without_tags.partition_point(|q| q.t_s < p.t_s);
            match (
                i.checked_sub(1).map(|k| &without_tags[k]),
                without_tags.get(i),
            ) {
                (Some(a), Some(b)) if b.t_s > a.t_s => {
                    let w = (p.t_s - a.t_s) / (b.t_s - a.t_s);
                    a.bound95_m + w * (b.bound95_m - a.bound95_m)
                }
                (_, Some(b)) => b.bound95_m,
                (Some(a), None) => a.bound95_m,
                (None, None) => f64::NAN,
            }
        };
        let _ = write!(s, "{:.3},{:.3},{:.4},", p.t_s, p.distance_m, p.bound95_m);
        if without.is_finite() {
            let _ = write!(s, "{without:.4}");
        }
        s.push('\n');
    }
    s
}
