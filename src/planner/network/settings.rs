//! The network-specific settings: the scenario's map route (the vehicles'
//! speed profile and height), candidate spacing and where walks may turn
//! back.

use crate::error::{Error, Result};
use crate::network::Network;
use crate::planner::settings::PlannerSettings;
use crate::scenario::{RouteKind, Scenario};
use crate::trajectory::SpeedProfile;

pub use crate::scenario::DEFAULT_NETWORK_SPACING_M;
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
            "planner.coverage = \"network\" needs a road map: give [map] (and no motion-command \
             route; the vehicles' speed is [vehicle] speed_kmh)",
        )),
    }
}

/// The scenario has a `[[route]]` with waypoints (ignored by network
/// coverage).
pub(crate) fn has_waypoints(scn: &Scenario) -> bool {
    matches!(&scn.route, RouteKind::Map { waypoints, .. } if !waypoints.is_empty())
}

/// Loads the road network of a network-coverage scenario.
pub fn scenario_network(scn: &Scenario) -> Result<Network> {
    let (map, _, _) = map_route(scn)?;
    Network::load(map, &Default::default())
}

pub use crate::scenario::UTurns;

/// Checks the network-specific settings: candidate spacing and U-turns.
pub(crate) fn check_settings(scn: &Scenario, settings: &PlannerSettings) -> Result<(f64, UTurns)> {
    let p = scn.planner();
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
    Ok((p.candidate_spacing_m, p.u_turns))
}
