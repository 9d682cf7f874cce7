//! `waymark network inspect`: a map's counts, components and defects.

use crate::error::{Error, Result};
use crate::export::defects_geojson;
use crate::fsio::write_atomic;
use crate::network::{inspect, Inspection, LoadOptions, Network};
use std::path::Path;
use std::time::Instant;

/// What `inspect_map` found.
pub type InspectOutcome = Inspection;

/// Loads the map, checks it for defects (unjoined nodes closer than
/// `tolerance_m`, and the rest `Network::defects` finds) and, with
/// `defects_out`, writes every defect as a GeoJSON point.
pub fn inspect_map(
    map: &Path,
    options: &LoadOptions,
    tolerance_m: f64,
    defects_out: Option<&Path>,
) -> Result<InspectOutcome> {
    if !(tolerance_m.is_finite() && tolerance_m >= 0.0) {
        return Err(Error::InvalidParameter(format!(
            "--tolerance must be a non-negative number of metres, got {tolerance_m}"
        )));
    }
    if let Some(path) = defects_out {
        // Checked before the map is loaded: its folder must exist.
        let dir = path.parent().filter(|d| !d.as_os_str().is_empty());
        if let Some(d) = dir.filter(|d| !d.is_dir()) {
            return Err(Error::format(
                path,
                format!("cannot write the defects: {} is not a folder", d.display()),
            ));
        }
        super::inputs::check_distinct_files(&[(path, "--defects")], &[(map, "MAP")])?;
    }
    let net = Network::load(map, options)?;
    let t = Instant::now();
    let defects = net.defects(tolerance_m);
    let defects_ms = t.elapsed().as_secs_f64() * 1e3;
    let report = inspect(&map.display().to_string(), &net, &defects, defects_ms);
    if let Some(path) = defects_out {
        write_atomic(path, defects_geojson(&defects).as_bytes())?;
    }
    Ok(report)
}
