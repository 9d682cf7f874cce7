//! What a plan writes to its output folder: the export records of its new
//! tags (with payloads) and the metadata of the tag files, for route and
//! network plans alike.

use super::budget::{AllRead, Budget};

use super::network::types::NetworkPlan;
use super::plan::Plan;
pub use super::record::MISSED_GRID_M;
use crate::error::Result;
use crate::scenario::{RouteKind, Scenario};
use crate::sim::tags::Mounting;
use crate::sim::TruthSource;
use crate::tags::TagPayload;
use crate::tags::{ExportMetadata, TagRecord};

impl Plan {
    /// The largest predicted 95 % horizontal bound along the route with
    /// any `k` consecutive tags missed (`k` = the tolerated missed reads):
    /// for each window of `k` consecutive tags, the filter just before its
    /// first tag run to the end of the route without them and with every
    /// later tag read (the covariance check the plan was made to pass, here
    /// run to the end rather than stopped at the requirement — or stopped
    /// once it provably cannot raise the worst bound,
    /// [`Budget::worst_bound_settled`]), and the
    /// all-read bound. `None` when no read is tolerated or there are no tags.
    /// The tags are matched to the truth samples by their pass time.
    pub fn missed_bound(&self, scn: &Scenario, truth: &TruthSource) -> Option<f64> {
        let k = self.tolerate_missed_reads;
        if k == 0 || self.tags.is_empty() {
            return None;
        }
        let network = match scn.route {
            RouteKind::Map { .. } => truth.network().map(|n| &**n),
            _ => None,
        };
        let budget = Budget::new(scn, truth, network);
        self.missed_bound_on(&budget)
    }

    /// [`Plan::missed_bound`] on the route's covariance analysis `budget`
    /// (the planner's own, so that its filter passes are counted).
    pub fn missed_bound_on(&self, budget: &Budget<'_>) -> Option<f64> {
        self.missed_bound_with(budget, None)
    }

    /// [`Plan::missed_bound_on`], reusing `all` when it is the all-read
    /// pass it needs: the plan's fixes, snapshots at them and the largest
    /// bound on a `MISSED_GRID_M` grid
    /// ([`Budget::all_read_gridded`]); the same numbers, one pass fewer.
    pub fn missed_bound_with(&self, budget: &Budget<'_>, all: Option<&AllRead>) -> Option<f64> {
        self.missed_bound_reusing(budget, all.map(|a| (a, None)))
    }

    /// [`Plan::missed_bound_with`], also reusing the windows' largest bound
    /// when given with `all` ([`Budget::missed_worst`] of `all` and the
    /// plan's `k`, below the requirement: the forward check's, which
    /// computed it).
    pub(crate) fn missed_bound_reusing(
        &self,
        budget: &Budget<'_>,
        all: Option<(&AllRead, Option<f64>)>,
    ) -> Option<f64> {
        let k = self.tolerate_missed_reads;
        if k == 0 || self.tags.is_empty() {
            return None;
        }
        let samples = budget.samples();
        if samples.is_empty() {
            return None;
        }
        let fixes: Vec<(usize, Mounting)> = self
            .tags
            .iter()
            .map(|t| {
                let i = samples.partition_point(|x| x.avp.t < t.t_s - 1e-9);
                (i.min(samples.len() - 1), t.mounting)
            })
            .collect();
        let at: Vec<f64> = fixes
            .iter()
            .map(|&(i, _)| samples[i].avp.distance_m)
            .collect();
        let own;
        let (all, worst) = match all {
            Some((a, w)) if a.fixes == fixes && a.grid_m == MISSED_GRID_M => (a, w),
            _ => {
                own = budget.all_read(&fixes, MISSED_GRID_M, &at);
                (&own, None)
            }
        };
        let all_read = all.grid_max;
        let n = fixes.len();
        if all.sites.len() != n {
            return None;
        }
        // Each window's exact worst bound (the candidates' only).
        let worst = worst.unwrap_or_else(|| budget.missed_worst(all, k, f64::INFINITY));
        Some(all_read.max(worst))
    }

    /// Export records (with payloads) and metadata.
    pub fn export(&self, scn: &Scenario) -> Result<(Vec<TagRecord>, ExportMetadata)> {
        let mut recs = Vec::with_capacity(self.tags.len());
        for (i, t) in self.tags.iter().enumerate().filter(|(_, t)| !t.existing) {
            let payload = TagPayload {
                lat_deg: t.lat,
                lon_deg: t.lon,
                height_m: t.height_m,
                mounting: t.mounting,
            }
            .to_hex()?;
            recs.push(TagRecord {
                tag_id: t.tag_id.clone(),
                lat: t.lat,
                lon: t.lon,
                height_m: t.height_m,
                road_id: t.road_id.clone(),
                // Along the road where there is one (what installers
                // measure), else along the route.
                chainage_m: Some(t.road_chainage_m.unwrap_or(t.route_distance_m)),
                // Roadside readers look right (right-hand traffic): the
                // post is on the right of travel, i.e. left of the road's
                // digitised direction when driving against it.
                side: Some(
                    match (t.mounting, t.digitised_forward) {
                        (Mounting::Roadside, Some(false)) => "left",
                        (Mounting::Roadside, _) => "right",
                        _ => "centre",
                    }
                    .to_string(),
                ),
                // Roadside tags stand x to the right of the lane centre
                // (their stored point is the lane centre abeam).
                lateral_offset_m: Some(match t.mounting {
                    Mounting::Roadside => scn.rfid.roadside_distance_m,
                    _ => 0.0,
                }),
                mounting: t.mounting,
                expected_fix_sigma_m: Some(t.expected_fix_sigma_m),
                // Tags within one window of k+1 consecutive tags back each other up.
                redundancy_group: Some((i / (self.tolerate_missed_reads + 1)) as u32),
                payload_hex: Some(payload),
                reason: Some(t.reason.clone()),
            });
        }
        let on_map = matches!(scn.route, RouteKind::Map { .. });
        // Lane widths as the plan used them: per site from the road on a
        // map, else the scenario's.
        let widths: Vec<f64> = self
            .tags
            .iter()
            .map(|t| t.lane_width_m.unwrap_or(scn.rfid.lane_width_m))
            .collect();
        let mut meta = common_metadata(
            scn,
            &self.scenario,
            &self.method,
            self.requirement_m,
            self.tolerate_missed_reads,
            &widths,
        );
        let p = &mut meta.parameters;
        p.insert("coverage".into(), "route".into());
        p.insert(
            "chainage_m".into(),
            if on_map {
                "distance along road_id in its digitised direction".into()
            } else {
                "distance along the planned route".into()
            },
        );
        p.insert(
            "redundancy_group".into(),
            "tags within one window of k+1 consecutive tags along the route".into(),
        );
        // Motion-command routes carry the trajectory's heights; map routes
        // the terrain's with `[map] elevation`, else a constant height.
        meta.heights_known = !on_map || !scn.elevation.is_empty();
        if on_map {
            meta.attribution = Some("© OpenStreetMap contributors, ODbL".into());
        }
        Ok((recs, meta))
    }
}

impl NetworkPlan {
    /// Export records of the new tags (with payloads) and metadata.
    pub fn export(&self, scn: &Scenario) -> Result<(Vec<TagRecord>, ExportMetadata)> {
        let mut recs = Vec::new();
        for t in self.tags.iter().filter(|t| !t.existing) {
            let payload = TagPayload {
                lat_deg: t.lat,
                lon_deg: t.lon,
                height_m: t.height_m,
                mounting: t.mounting,
            }
            .to_hex()?;
            // Side of the road's digitised direction the tag is on: the
            // lane (and roadside post) right of travel.
            let side = if t.oneway && t.mounting != Mounting::Roadside {
                "centre"
            } else if t.digitised_forward {
                "right"
            } else {
                "left"
            };
            recs.push(TagRecord {
                tag_id: t.tag_id.clone(),
                lat: t.lat,
                lon: t.lon,
                height_m: t.height_m,
                road_id: Some(t.road_id.clone()),
                chainage_m: Some(t.chainage_m),
                side: Some(side.to_string()),
                lateral_offset_m: Some(match t.mounting {
                    Mounting::Roadside => scn.rfid.roadside_distance_m,
                    _ => 0.0,
                }),
                mounting: t.mounting,
                expected_fix_sigma_m: Some(t.expected_fix_sigma_m),
                redundancy_group: Some(t.edge),
                payload_hex: Some(payload),
                reason: Some(t.reason.clone()),
            });
        }
        // The fix error model uses the scenario's lane width; lane centres
        // (the tag positions) each road's own (lane_offset_m in plan.json).
        let mut meta = common_metadata(
            scn,
            &self.scenario,
            &self.method,
            self.requirement_m,
            self.tolerate_missed_reads,
            &[scn.rfid.lane_width_m],
        );
        let p = &mut meta.parameters;
        p.insert("coverage".into(), "network".into());
        p.insert("reach_m".into(), format!("{:.1}", self.reach_m));
        p.insert(
            "budget_reference_m".into(),
            format!("{:.1}", self.budget_reference_m),
        );
        p.insert("reach_levels".into(), self.reach_levels.to_string());
        p.insert("u_turns".into(), self.u_turns.clone());
        p.insert(
            "candidate_spacing_m".into(),
            self.candidate_spacing_m.to_string(),
        );
        p.insert(
            "chainage_m".into(),
            "distance along the road (road_id) in its digitised direction".into(),
        );
        p.insert(
            "side".into(),
            "side of the road's digitised direction (right-hand traffic: the lane of the direction served); \
             the position is the lane centre; lateral_offset_m is a roadside post's distance right of it"
                .into(),
        );
        p.insert(
            "redundancy_group".into(),
            "directed road section (section and direction) the tag serves".into(),
        );
        meta.heights_known = false;
        meta.parameters
            .insert("height_m".into(), heights_on_map(scn, true));
        meta.attribution = Some("© OpenStreetMap contributors, ODbL".into());
        Ok((recs, meta))
    }
}

/// Where a map plan's heights come from (`height_m` in the tag files'
/// metadata and the report's "Heights:" line).
fn heights_on_map(scn: &Scenario, network: bool) -> String {
    let constant = match scn.route {
        RouteKind::Map { height_m, .. } => height_m,
        RouteKind::Motion { .. } => 0.0,
    };
    match (scn.elevation.is_empty(), network) {
        (true, _) => format!(
            "none (no [map] elevation): every tag carries the route's constant height, \
             {constant} m, not the terrain's"
        ),
        (false, false) => format!(
            "the terrain's, from the elevation model {} (bilinear, smoothed along the road; \
             tunnels and bridges interpolated between their ends)",
            scn.elevation
                .iter()
                .map(|p| p.display().to_string())
                .collect::<Vec<_>>()
                .join(", ")
        ),
        (false, true) => format!(
            "none: these tags were not given the terrain's heights (the plan command gives \
             them from [map] elevation); every tag carries {constant} m"
        ),
    }
}

/// The metadata route and area plans share: the scenario, the method, the
/// requirement, the missed reads tolerated and the RFID model's parameters
/// as the plan used them (`lane_widths_m`: the lane widths of the sites,
/// written as one value when they agree, else as their range), and what
/// the heights are.
fn common_metadata(
    scn: &Scenario,
    scenario: &str,
    method: &str,
    requirement_m: f64,
    tolerate_missed_reads: usize,
    lane_widths_m: &[f64],
) -> ExportMetadata {
    let mut meta = ExportMetadata::new(Some(requirement_m));
    let r = &scn.rfid;
    let p = &mut meta.parameters;
    p.insert("scenario".into(), scenario.to_string());
    p.insert("method".into(), method.to_string());
    p.insert(
        "tolerate_missed_reads".into(),
        tolerate_missed_reads.to_string(),
    );
    p.insert("read_probability".into(), r.read_probability.to_string());
    let lo = lane_widths_m.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = lane_widths_m.iter().copied().fold(0.0, f64::max);
    p.insert(
        "lane_width_m".into(),
        if lane_widths_m.is_empty() {
            r.lane_width_m.to_string()
        } else if hi - lo < 1e-9 {
            lo.to_string()
        } else {
            format!("{lo}..{hi} (per site: the road's OSM width/lanes or its class)")
        },
    );
    p.insert("vehicle_width_m".into(), r.vehicle_width_m.to_string());
    p.insert(
        "roadside_distance_m".into(),
        r.roadside_distance_m.to_string(),
    );
    p.insert(
        "roadside_angle_deg".into(),
        format!("{:.3}", r.roadside_angle.to_degrees()),
    );
    p.insert("read_time_s".into(), r.read_time_s.to_string());
    p.insert(
        "road_surface_sigma_m".into(),
        r.road_surface_sigma_m.to_string(),
    );
    p.insert("ceiling_sigma_m".into(), r.ceiling_sigma_m.to_string());
    p.insert(
        "height_m".into(),
        if matches!(scn.route, RouteKind::Map { .. }) {
            heights_on_map(scn, false)
        } else {
            "the trajectory's height (from the start height and the motion commands)".into()
        },
    );
    meta
}

impl Budget<'_> {
    /// The largest bound of the missed-read windows of the all-read pass
    /// `all` (its fixes, snapshots at them; [`Budget::all_read`]) with `k`
    /// consecutive fixes missed: for each window (fixes `d..d + k` missed),
    /// its filter just before fix `d` run to the end with every later fix
    /// read, its pass stopped once the rest of the route cannot raise its
    /// worst ([`Budget::worst_bound_settled`]); 0 without windows. When
    /// it exceeds `stop_above_m`, some value above that (the runs stop
    /// early); otherwise the runs are the same as with no stop.
    ///
    /// With the stretch maps, only the windows that may hold the largest
    /// are run so, and the value is the same as running them all, for less
    /// work (0.97 → 0.20 counted passes on the RFID paper's drive):
    ///
    /// 1. The window likely the worst (its filter carried by the maps to
    ///    the next read fix has the largest bound there) is run exactly
    ///    first, giving `w`.
    /// 2. The others are run with the settle level `s = max(w, a) · (1 −`
    ///    `WINDOW_MARGIN``)`, `a` the all-read bound
    ///    ([`AllRead::grid_max`], part of the missed-read bound): the maps
    ///    carry them almost everywhere. A result at most `s` proves that
    ///    window's worst at most `s` (up to the 1e-9 margins of the maps and
    ///    of the settle test), below `max(w, a)`, so it cannot raise the
    ///    result; a window above `s` is run exactly.
    pub fn missed_worst(&self, all: &AllRead, k: usize, stop_above_m: f64) -> f64 {
        use rayon::prelude::*;
        let fixes = &all.fixes;
        let n = fixes.len();
        if k == 0 || n == 0 || all.sites.len() != n {
            return 0.0;
        }
        let run = |d: usize, settle: f64| {
            self.worst_bound_settled(
                fixes[d].0,
                all.sites[d].filter.clone(),
                all,
                d + k,
                stop_above_m,
                settle,
            )
        };
        let windows = n.saturating_sub(k - 1).max(1);
        if self.stretches().is_none() {
            return (0..windows)
                .into_par_iter()
                .map(|d| run(d, 0.0))
                .reduce(|| 0.0, f64::max);
        }
        // The window likely the worst, run exactly first: the one whose
        // filter, carried by the maps (and stepped at the ends), has the
        // largest bound at the next read fix's sample (or the route's last);
        // with two windows or fewer, without that probe (it costs about what
        // a wrong guess does), the one with the longest stretch without a
        // read fix. Measured: demo plan 4.24 / 4.21 passes with / without
        // the probe; tags every 300 and 150 m on the demo, k = 1, 2 (test
        // `missed_worst_runs_only_the_candidate_windows`): 4.49 passes in
        // all with it, 4.66 without, 8.94 running every window exactly.
        let last = self.samples().len() - 1;
        let gap = |d: usize| {
            let before = d.checked_sub(1).map_or(0, |j| fixes[j].0);
            (fixes.get(d + k).map_or(last, |x| x.0) - before) as f64
        };
        let probe: Vec<f64> = (0..windows)
            .into_par_iter()
            .map(|d| {
                let from = fixes[d].0;
                let to = fixes.get(d + k).map_or(last, |x| x.0);
                if windows <= 2 {
                    return gap(d);
                }
                if to <= from {
                    return 0.0;
                }
                let g = self.filter_at(from, all.sites[d].filter.clone(), to);
                self.bound(&g.position_cov_enu())
            })
            .collect();
        let first = (0..windows).fold(0, |b, d| if probe[d] > probe[b] { d } else { b });
        let w = run(first, 0.0);
        if w > stop_above_m {
            return w;
        }
        let settle = w.max(all.grid_max) * (1.0 - WINDOW_MARGIN);
        let rest = (0..windows)
            .into_par_iter()
            .filter(|&d| d != first && run(d, settle) > settle)
            .map(|d| run(d, 0.0))
            .reduce(|| 0.0, f64::max);
        tracing::debug!(windows, first, w, rest, "missed-read windows");
        w.max(rest)
    }
}

/// The relative margin of [`Budget::missed_worst`]'s settle level below
/// the largest bound known: a window's worst is certified under the level
/// with the stretch maps' 1e-9 margin
/// ([`super::stretch::INTERIOR_MARGIN`]; maps and steps differ by ≈ 1e-12
/// relative, at most 7e-11 with the filter's state: module `carry`) and
/// the settle test's 1e-9 ([`Budget::worst_bound_settled`]); 1e-8 is above
/// both, so a window certified under the level is below the largest bound.
const WINDOW_MARGIN: f64 = 1e-8;
