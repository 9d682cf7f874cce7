//! The network-specific settings: the scenario's map route (the vehicles'
//! speed profile and height), candidate spacing and where walks may turn
//! back.

use crate::error::{Error, Result};
use crate::network::Network;
use crate::planner::settings::PlannerSettings;
use crate::sim::scenario::{RouteKind, Scenario};
use crate::trajectory::SpeedProfile;

/// Default candidate spacing on networks (m).
pub const DEFAULT_NETWORK_SPACING_M: f64 = 50.0;
/// Largest instance (candidate sites) tried with the exact method.
pub const ILP_MAX_CANDIDATES: usize = 150;
/// Installed tags farther than this from every road are ignored (m).
pub const EXISTING_SNAP_M: f64 = 15.0;
/// The speed profile and height of a network scenario's route (vehicles'
/// speed), or an error when the scenario has no map.
pub(crate) fn map_route(scn: &Scenario) -> Result<(&std::path::Path, &SpeedProfile, f64)> {
    match &scn.route {
        RouteKind::Map {
            map,
            profile,
            height_m,
            ..
        } => Ok((map.as_path(), profile, *height_m)),
        RouteKind::Motion { .. } => Err(Error::scenario(
            &scn.path,
            "planner.coverage = \"network\" needs a road map: give [map] and a [[route]] with \
             waypoints (its speed_kmh is the vehicles' speed); a motion-command route has no network",
        )),
    }
}

/// Loads the road network of a network-coverage scenario.
pub fn scenario_network(scn: &Scenario) -> Result<Network> {
    let (map, _, _) = map_route(scn)?;
    Network::load(map, &Default::default())
}

/// Where walks may turn back onto the road they came along.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum UTurns {
    /// At any junction or road end (`"anywhere"`, the default): the
    /// topology's successors, the most conservative.
    Anywhere,
    /// Only at dead ends (`"dead_ends"`: nodes where a single road ends).
    DeadEnds,
}

/// Checks the network-specific settings: candidate spacing and U-turns.
pub(crate) fn check_settings(scn: &Scenario, settings: &PlannerSettings) -> Result<(f64, UTurns)> {
    let p = scn.file.planner.as_ref();
    if !settings.forbidden_m.is_empty() {
        return Err(Error::scenario(
            &scn.path,
            "planner.forbidden_m gives stretches of route distance and does not apply to \
             coverage = \"network\"",
        ));
    }
    if settings.min_spacing_m > 0.0 {
        return Err(Error::scenario(
            &scn.path,
            "planner.min_spacing_m is not supported with coverage = \"network\"",
        ));
    }
    let u = match p.and_then(|p| p.u_turns.as_deref()) {
        None | Some("anywhere") => UTurns::Anywhere,
        Some("dead_ends") => UTurns::DeadEnds,
        Some(o) => {
            return Err(Error::scenario(
                &scn.path,
                format!("planner.u_turns = \"{o}\" is not one of anywhere, dead_ends"),
            ))
        }
    };
    Ok((
        p.and_then(|p| p.candidate_spacing_m)
            .unwrap_or(DEFAULT_NETWORK_SPACING_M),
        u,
    ))
}
