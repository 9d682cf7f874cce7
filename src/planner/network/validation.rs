//! Monte Carlo validation of a network plan on seeded random
//! origin–destination shortest paths, each driven with the planned tags of
//! the directions it takes; the map is the one loaded for planning.

use super::settings::map_route;
use super::types::{NetworkPlan, NetworkValidation};
use crate::error::{Error, Result};
use crate::network::{Network, SectionId};
use crate::scenario::Scenario;
use crate::sim::{simulate_with, TruthSource};
use crate::trajectory::RoutePlan;
use std::collections::HashSet;

/// Monte Carlo validation over `runs` runs on seeded random
/// origin–destination shortest paths (1.5–4 km where the map allows; up to
/// 10 paths, the runs split between them).
pub fn validate_network_plan(
    scn: &Scenario,
    net: &std::sync::Arc<Network>,
    plan: &NetworkPlan,
    runs: u64,
    seed: u64,
) -> Result<NetworkValidation> {
    use rand::{Rng, SeedableRng};
    let (_, profile, height_m) = map_route(scn)?;
    let runs = runs.max(1);
    let n_paths = runs.min(10) as usize;
    let per_path = runs.div_ceil(n_paths as u64);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed ^ 0x6e65_7477_6f72_6b00);
    let nodes = &net.nodes;
    if nodes.len() < 2 {
        return Err(Error::InvalidParameter(
            "the network is too small to sample validation paths".into(),
        ));
    }
    let (mut within, mut total) = (0.0, 0.0);
    let mut worst = (0.0f64, 0usize, 0u64, 0.0, 0.0, [0.0, 0.0], None);
    let mut paths = 0usize;
    let mut length = 0.0;
    let mut attempts = 0;
    while paths < n_paths && attempts < 20 * n_paths {
        attempts += 1;
        let o = rng.random_range(0..nodes.len());
        let mut best: Option<(usize, f64)> = None;
        for _ in 0..100 {
            let d = rng.random_range(0..nodes.len());
            let dist = (nodes[o].enu[0] - nodes[d].enu[0]).hypot(nodes[o].enu[1] - nodes[d].enu[1]);
            if (1500.0..=4000.0).contains(&dist) {
                best = Some((d, dist));
                break;
            }
            if dist <= 4000.0 && best.is_none_or(|b| dist > b.1) {
                best = Some((d, dist));
            }
        }
        let Some((d, dist)) = best else { continue };
        if dist < 200.0 {
            continue;
        }
        let Ok(route) = crate::route::plan_route(net, &[nodes[o].lat_lon, nodes[d].lat_lon]) else {
            continue;
        };
        if route.length_m < 200.0 {
            continue;
        }
        let Ok(rp) = RoutePlan::new(net, &route, profile, &[], height_m, scn.dt) else {
            continue;
        };
        let dirs: HashSet<(SectionId, bool)> = route
            .spans
            .iter()
            .map(|s| (s.section.section, s.section.forward))
            .collect();
        let tags = plan.sim_tags(Some(&dirs));
        let route_length_m = route.length_m;
        let truth = TruthSource::from_route(std::sync::Arc::clone(net), route, rp);
        let route = truth.route().expect("a route truth");
        let res = simulate_with(
            scn,
            &truth,
            &tags,
            per_path,
            seed + 1000 * paths as u64,
            None,
        )?;
        length += route_length_m;
        for r in &res.runs {
            for w in r.rows.windows(2) {
                let dd = (w[1].distance_m - w[0].distance_m).max(0.0);
                total += dd;
                if w[1].horizontal_m <= plan.requirement_m {
                    within += dd;
                }
            }
            for row in &r.rows {
                if row.horizontal_m > worst.0 {
                    worst = (
                        row.horizontal_m,
                        paths,
                        r.run,
                        row.t_s,
                        row.distance_m,
                        [0.0, 0.0],
                        None,
                    );
                }
            }
        }
        if worst.1 == paths && worst.0 > 0.0 {
            // Where the worst point is (truth position at its time).
            if let Some(a) = truth.samples().find(|a| a.t >= worst.3 - 0.5 * scn.dt) {
                worst.5 = [a.state.lat.to_degrees(), a.state.lon.to_degrees()];
                let scale = route.length_m
                    / truth
                        .samples()
                        .last()
                        .map_or(1.0, |x| x.distance_m.max(1.0));
                let span = route.span_at(worst.4 * scale);
                worst.6 = Some(net.roads[span.road as usize].attributes.id.clone());
            }
        }
        paths += 1;
    }
    if paths == 0 {
        return Err(Error::InvalidParameter(
            "no validation path could be sampled on the network (too small or disconnected)".into(),
        ));
    }
    Ok(NetworkValidation {
        runs: per_path * paths as u64,
        paths,
        runs_per_path: per_path,
        paths_length_km: length / 1000.0,
        seed,
        fraction_within_requirement: if total > 0.0 { within / total } else { 1.0 },
        max_horizontal_error_m: worst.0,
        worst_path: worst.1,
        worst_run: worst.2,
        worst_t_s: worst.3,
        worst_distance_m: worst.4,
        worst_lat: worst.5[0],
        worst_lon: worst.5[1],
        worst_road_id: worst.6,
    })
}
