//! `waymark init`: a commented starting scenario, on a map when one is
//! given (two waypoints chosen on it so that the route plans), else a drive
//! by motion commands.

use super::inputs::check_out_dir;
use crate::error::{Error, Result};
use crate::fsio::write_atomic;
use crate::scenario::{starter_scenario, Scenario, Starter};
use serde::Serialize;
use std::path::{Path, PathBuf};

/// What `init_scenario` wrote.
#[derive(Debug, Clone, Serialize)]
pub struct InitOutcome {
    /// The scenario file written.
    pub scenario: PathBuf,
    /// The map it names, if any.
    pub map: Option<PathBuf>,
    /// Its waypoints ([lat, lon] degrees), on a map.
    pub waypoints: Vec<[f64; 2]>,
    /// Whether it plans network coverage.
    pub network: bool,
}

/// Writes a starting scenario to `out` (which must not exist yet): on
/// `map` when given (waypoints: the farthest pair of section ends, among
/// an even sample of them, that a route joins), else a motion-command
/// drive. `network` sets `coverage = "network"` (it needs a map). The
/// written file is parsed back before it is kept.
pub fn init_scenario(out: &Path, map: Option<&Path>, network: bool) -> Result<InitOutcome> {
    if out.exists() {
        return Err(Error::format(
            out,
            "already exists: waymark init does not overwrite a file",
        ));
    }
    if network && map.is_none() {
        return Err(Error::InvalidParameter(
            "--network plans tags on a map's roads: give the map with --map MAP".into(),
        ));
    }
    if let Some(parent) = out.parent() {
        check_out_dir(parent)?;
    }
    let name = out
        .file_stem()
        .and_then(|s| s.to_str())
        .unwrap_or("scenario")
        .to_string();
    let (map_text, waypoints) = match map {
        Some(m) => {
            let net = crate::network::Network::load(m, &crate::network::LoadOptions::default())?;
            let wps = pick_waypoints(&net).ok_or_else(|| {
                Error::format(m, "no two points of the map are joined by a drivable route")
            })?;
            let abs = std::fs::canonicalize(m).map_err(|e| Error::io(m, e))?;
            (Some(abs.display().to_string()), wps)
        }
        None => (None, Vec::new()),
    };
    let text = starter_scenario(&Starter {
        map: map_text,
        waypoints: waypoints.clone(),
        network,
        name,
    });
    // The file must be one the other commands accept.
    Scenario::parse(out, &text)?;
    if let Some(parent) = out.parent().filter(|p| !p.as_os_str().is_empty()) {
        std::fs::create_dir_all(parent).map_err(|e| Error::io(parent, e))?;
    }
    write_atomic(out, text.as_bytes())?;
    Ok(InitOutcome {
        scenario: out.to_path_buf(),
        map: map.map(Path::to_path_buf),
        waypoints,
        network,
    })
}

/// Two far-apart section ends a route joins: among up to 24 ends spread
/// evenly over the sections, the pairs in order of distance, the first
/// that plans (at most 40 tried).
fn pick_waypoints(net: &crate::network::Network) -> Option<Vec<[f64; 2]>> {
    let n = net.sections.len();
    if n == 0 {
        return None;
    }
    let step = (n / 24).max(1);
    let ends: Vec<[f64; 2]> = (0..n)
        .step_by(step)
        .map(|i| {
            let segs = net.model.section_segments(i as u32);
            let p = segs[segs.len() / 2].a;
            let g = net.frame.to_geodetic([p[0], p[1], 0.0]);
            ([p[0], p[1]], [g.lat_deg(), g.lon_deg()])
        })
        .map(|(_, ll)| ll)
        .collect();
    let enu = |ll: [f64; 2]| {
        let p = net
            .frame
            .to_enu(&crate::geodesy::Geodetic::from_degrees(ll[0], ll[1], 0.0));
        [p[0], p[1]]
    };
    let mut pairs = Vec::new();
    for i in 0..ends.len() {
        for j in i + 1..ends.len() {
            let (a, b) = (enu(ends[i]), enu(ends[j]));
            pairs.push(((a[0] - b[0]).hypot(a[1] - b[1]), i, j));
        }
    }
    pairs.sort_by(|x, y| y.0.total_cmp(&x.0));
    pairs
        .into_iter()
        .take(40)
        .map(|(_, i, j)| vec![ends[i], ends[j]])
        .find(|w| crate::route::plan_route(net, w).is_ok())
}
