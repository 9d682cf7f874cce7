//! Writing output files: every file is written to a temporary file beside its
//! destination and renamed into place, so it appears completely or not at all.

mod tags;

pub use tags::{
    tags_csv, tags_geojson, tags_gpx, tags_kml, ExportMetadata, TagRecord, CSV_COLUMNS,
};

use crate::error::{Error, Result};
use std::io::Write;
use std::path::Path;

/// Writes `bytes` to `path` atomically (temporary file, then rename).
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    let name = path
        .file_name()
        .ok_or_else(|| Error::InvalidParameter(format!("{}: not a file path", path.display())))?;
    let tmp = dir.join(format!(
        ".{}.tmp{}",
        name.to_string_lossy(),
        std::process::id()
    ));
    let result = (|| -> std::io::Result<()> {
        let mut f = std::fs::File::create(&tmp)?;
        f.write_all(bytes)?;
        f.sync_all()?;
        std::fs::rename(&tmp, path)
    })();
    if let Err(e) = result {
        let _ = std::fs::remove_file(&tmp);
        return Err(Error::io(path, e));
    }
    Ok(())
}

/// The defects as a GeoJSON FeatureCollection of points (RFC 7946, [lon, lat]).
pub fn defects_geojson(defects: &crate::network::DefectReport) -> String {
    let features: Vec<serde_json::Value> = defects
        .items
        .iter()
        .map(|d| {
            serde_json::json!({
                "type": "Feature",
                "geometry": {"type": "Point", "coordinates": [d.lat_lon[1], d.lat_lon[0]]},
                "properties": {"kind": d.kind, "roads": d.roads, "detail": d.detail},
            })
        })
        .collect();
    serde_json::to_string_pretty(&serde_json::json!({
        "type": "FeatureCollection",
        "features": features,
    }))
    .unwrap_or_default()
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn atomic_write_replaces_and_leaves_no_temporary() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("out.txt");
        write_atomic(&p, b"one").unwrap();
        write_atomic(&p, b"two").unwrap();
        assert_eq!(std::fs::read(&p).unwrap(), b"two");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
    }

    #[test]
    fn atomic_write_into_missing_folder_fails_cleanly() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("missing").join("out.txt");
        assert!(write_atomic(&p, b"x").is_err());
        assert!(!p.exists());
    }
}
