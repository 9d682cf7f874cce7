//! The selected candidate sites of a network plan as tags: positions on the
//! lane of the direction served (installed tags keep theirs), heights,
//! mountings, expected fix quality and the reason each is needed.

use super::instance::{section_point, Built};
use super::types::NetworkTag;
use crate::network::Network;
use crate::planner::settings::{lane_width_m, NewTagIds, PlannerSettings};
use crate::scenario::Scenario;

/// The selected sites as tags (installed ones keep their id and position),
/// each with its reason; and the cost of the new ones.
pub(super) fn tags_of(
    scn: &Scenario,
    settings: &PlannerSettings,
    net: &Network,
    built: &Built,
    sel: &[bool],
    height_m: f64,
    reason: impl Fn(usize) -> String,
) -> (Vec<NetworkTag>, f64) {
    let p = &built.problem;
    let mut tags = Vec::new();
    let mut new_ids = NewTagIds::new("N", 5, scn, settings);
    let mut total_cost = 0.0;
    for (i, site) in p.sites.iter().enumerate() {
        if !sel[i] {
            continue;
        }
        let (sec, fwd) = built.edge_dir[site.edge as usize];
        let s = &net.sections[sec as usize];
        let a = &net.roads[s.road as usize].attributes;
        let at = site.at_m / built.edge_scale[site.edge as usize];
        let off = if fwd { at } else { s.length_m - at };
        let (ll, enu, chain, dir) = section_point(net, sec, off);
        let oneway = s.oneway.is_oneway();
        let lane = if oneway { 0.0 } else { 0.5 * lane_width_m(a) };
        // Right of travel: digitised right when forward, left when backward.
        let sign = if fwd { 1.0 } else { -1.0 };
        let right = [dir[1] * sign, -dir[0] * sign];
        let g = net
            .frame
            .to_geodetic([enu[0] + lane * right[0], enu[1] + lane * right[1], 0.0]);
        let existing = built.site_existing[i].map(|ti| &settings.existing_tags[ti]);
        let m = built.site_mounting[i];
        let (sa, sc) = scn.rfid.fix_sigmas(m, built.edge_speed[site.edge as usize]);
        if existing.is_none() {
            total_cost += site.cost;
        }
        tags.push(NetworkTag {
            tag_id: existing.map_or_else(|| new_ids.next_id(), |t| t.id.clone()),
            lat: existing.map_or(g.lat_deg(), |t| t.lat.to_degrees()),
            lon: existing.map_or(g.lon_deg(), |t| t.lon.to_degrees()),
            centre_lat: ll[0],
            centre_lon: ll[1],
            height_m: existing.and_then(|t| t.height_m).unwrap_or(height_m),
            road_id: a.id.clone(),
            road_name: a.name.clone(),
            chainage_m: chain,
            digitised_forward: fwd,
            oneway,
            mounting: m,
            expected_fix_sigma_m: sa.max(sc),
            tunnel: a.tunnel,
            existing: existing.is_some(),
            cost: site.cost,
            lane_offset_m: lane,
            edge: site.edge,
            section: sec,
            reason: reason(i),
        });
    }
    (tags, total_cost)
}
