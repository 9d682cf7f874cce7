//! `waymark plan`: plan, validate, write the plan folder.

use super::inputs::{
    check_inputs_outside_outputs, check_out_dir, clear_outputs, keep_inputs, scenario_inputs,
    PLAN_OUTPUTS,
};
use super::progress::Progress;
use crate::elevation::Dem;
use crate::error::{Error, Result};
use crate::export::{plan_profile_csv, tags_csv, tags_geojson, tags_gpx, tags_kml, tags_meta_json};
use crate::fsio::write_atomic;
use crate::planner::network::{
    plan_network_on, scenario_network, validate_network_plan, NetworkPlan,
};
use crate::planner::validation::validate_plan_on;
use crate::planner::{
    plan_with_stages, uniform_baseline, Coverage, Plan, PlanStage, PlannerSettings,
};
use crate::scenario::Scenario;
use crate::sim::tags::{parse_tags_csv, Tag};
use crate::sim::SimResult;
use crate::sim::TruthSource;
use crate::tags::{ExportMetadata, TagRecord};
use crate::trajectory::NetworkHeights;
use serde::Serialize;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// What to plan and where to write it.
#[derive(Debug, Clone, Copy)]
pub struct PlanJob<'a> {
    /// The scenario file.
    pub scenario: &'a Path,
    /// The output folder (created if missing).
    pub out_dir: &'a Path,
    /// Validation runs (default: the scenario's `planner.validation_runs`; 0 skips).
    pub runs: Option<u64>,
    /// Base seed of the validation (default: the scenario's).
    pub seed: Option<u64>,
    /// Also search the uniform-spacing baseline (route coverage only).
    pub baseline: bool,
}

/// `plan.json` of a route plan: the plan and the figures derived from it.
#[derive(Debug, Clone, Serialize)]
pub struct RoutePlanFile {
    /// The plan.
    #[serde(flatten)]
    pub plan: Plan,
    /// New tags.
    pub tag_count: usize,
    /// Installed tags kept.
    pub existing_tags_kept: usize,
    /// New tags by mounting.
    pub tags_by_mounting: BTreeMap<String, usize>,
    /// The Waymark version that planned.
    pub waymark_version: &'static str,
    /// Planning time before validation (s).
    pub plan_time_s: f64,
    /// The tag files' metadata (as `tags.meta.json`).
    pub tag_files: ExportMetadata,
}

/// `plan.json` of a network plan.
#[derive(Debug, Clone, Serialize)]
pub struct NetworkPlanFile {
    /// The plan.
    #[serde(flatten)]
    pub plan: NetworkPlan,
    /// New tags.
    pub tag_count: usize,
    /// New tags by mounting.
    pub tags_by_mounting: BTreeMap<String, usize>,
    /// The Waymark version that planned.
    pub waymark_version: &'static str,
    /// Planning time before validation (s).
    pub plan_time_s: f64,
    /// The tag files' metadata (as `tags.meta.json`).
    pub tag_files: ExportMetadata,
}

/// Counts by kind in words ("3 road_surface, 1 wall"; "none" when empty),
/// as the plan summaries print tags by mounting.
pub(super) fn counts_by_kind(m: &BTreeMap<String, usize>) -> String {
    let v: Vec<String> = m.iter().map(|(k, v)| format!("{v} {k}")).collect();
    if v.is_empty() {
        "none".to_string()
    } else {
        v.join(", ")
    }
}

impl NetworkPlanFile {
    /// The plan in words, line by line, as `waymark plan` prints it.
    pub fn summary(&self) -> Vec<String> {
        let mut lines = Vec::new();
        let p = &self.plan;
        let f = self;
        lines.push(format!(
                "{}: network coverage: {} new tag(s) ({}){} on {} directed road sections ({:.1} km, {} candidates), total cost {:.1}; \
                 requirement {} m with {} missed read(s) tolerated; reach R = {:.0}–{:.0} m by speed class (slowest: steady {:.0} m, start {:.0} m); \
                 method: {}; lower bound {} tag(s); verified: {}",
                p.scenario,
                f.tag_count,
                counts_by_kind(&f.tags_by_mounting),
                if p.existing_kept > 0 { format!(" + {} installed", p.existing_kept) } else { String::new() },
                p.directed_edges,
                p.directed_length_km,
                p.candidates,
                p.total_cost,
                p.requirement_m,
                p.tolerate_missed_reads,
                p.reach_m,
                p.budget_reference_m,
                p.steady_reach_m,
                p.start_reach_m,
                p.method,
                p.lower_bound,
                match (&p.guarantee, p.verified) {
                    (Some(_), true) => "every sampled chain holds the error budget with ≤ k tags missed",
                    (None, true) => "no walk exceeds the error budget with ≤ k tags",
                    _ => "NO",
                },
            ));
        lines.push(format!(
            "traffic: {}{}; rule: {}",
            p.traffic,
            if p.map_matching {
                " (map matching credited)"
            } else {
                ""
            },
            p.rule
        ));
        if p.route_ignored {
            lines.push(format!("note: the scenario's [[route]] is ignored by network coverage (the map alone is planned; vehicles at [vehicle] speed_kmh = {:.0} km/h)", p.vehicle_speed_kmh));
        }
        if let Some(v) = &p.validation {
            lines.push(format!(
                    "validation: {} run(s) on {} fresh chain(s) of trips ({:.1} km, {:.1} h), seed {}: {:.2} % of time within {} m; {}; \
                     {} run(s) with a maximum above it (median run maximum {:.2} m); \
                     max horizontal error {:.2} m (chain {}, run {}, {:.0} m along it, at {:.6}, {:.6}{})",
                    v.runs,
                    v.paths,
                    v.paths_length_km,
                    v.chain_hours,
                    v.seed,
                    100.0 * v.fraction_within_requirement,
                    p.requirement_m,
                    v.rule,
                    v.runs_exceeding,
                    v.median_run_max_m,
                    v.max_horizontal_error_m,
                    v.worst_path,
                    v.worst_run,
                    v.worst_distance_m,
                    v.worst_lat,
                    v.worst_lon,
                    v.worst_road_id.as_ref().map(|r| format!(", road {r}")).unwrap_or_default()
                ));
            if let (Some(u), Some(n), Some(w), Some(m)) = (
                v.max_budget_without_tags,
                v.over_budget_samples,
                v.over_budget_within,
                v.over_budget_max_error_m,
            ) {
                lines.push(format!(
                    "where the plan's model needs tags (its budget without tags above 1, at most {u:.2} on these drives): \
                     {n} of {} samples, {w} within {} m; max error there {m:.2} m",
                    v.thinned_samples, p.requirement_m,
                ));
            }
            if let Some(b) = &v.without_new_tags {
                lines.push(format!(
                    "baseline: the same chains, runs and seeds {}: {:.2} % of time within {} m; {}; \
                     {} run(s) with a maximum above it (median run maximum {:.2} m); max horizontal error {:.2} m \
                     (chain {}, run {}, t = {:.0} s{}){}; \
                     map matching on the wrong road {:.2} % of fixes (with the plan {:.2} %)",
                    if b.tags > 0 {
                        format!("with only the {} installed tag(s)", b.tags)
                    } else {
                        "without any tag".to_string()
                    },
                    100.0 * b.fraction_within_requirement,
                    p.requirement_m,
                    b.rule,
                    b.runs_exceeding,
                    b.median_run_max_m,
                    b.max_horizontal_error_m,
                    b.worst_path,
                    b.worst_run,
                    b.worst_t_s,
                    b.worst_road_id.as_ref().map(|r| format!(", road {r}")).unwrap_or_default(),
                    match (b.over_budget_within, v.over_budget_samples, b.over_budget_max_error_m) {
                        (Some(w), Some(n), Some(m)) => format!(
                            "; where the model needs tags {w} of {n} samples within, max error there {m:.2} m"
                        ),
                        _ => String::new(),
                    },
                    100.0 * b.map_matching_wrong_road_share,
                    100.0 * v.map_matching_wrong_road_share,
                ));
            }
            if let Some(st) = &v.over_budget_stretches {
                lines.push(format!(
                    "over-budget stretches: the {} where the plan's budget without tags peaks highest on {} fresh chains ({:.2}–{:.2}), \
                     each driven {} time(s) from {:.0} m before its turn, on the samples over budget: with the plan {}, max error {:.2} m; \
                     without the new tags {}, max error {:.2} m",
                    st.stretches,
                    st.searched_chains,
                    st.peak_budget_min,
                    st.peak_budget_max,
                    st.runs_per_stretch,
                    st.lead_in_m,
                    st.with_tags.rule,
                    st.with_tags.max_horizontal_error_m,
                    st.without_new_tags.rule,
                    st.without_new_tags.max_horizontal_error_m,
                ));
            }
            if let Some(d) = &v.design_walks {
                lines.push(format!(
                    "validation on the walk DP's {} worst walk(s), {} run(s) each, their tags missed and every other tag read: {}; \
                     {} run(s) with a maximum above {} m; max horizontal error {:.2} m (walk {})",
                    d.walks,
                    d.runs_per_walk,
                    d.figures.rule,
                    d.figures.runs_exceeding,
                    p.requirement_m,
                    d.figures.max_horizontal_error_m,
                    d.worst_walk
                ));
            }
        }
        lines
    }
}

/// The plan written, by coverage.
#[derive(Debug, Clone, Serialize)]
#[serde(untagged)]
pub enum PlanFiles {
    /// A route plan.
    Route(Box<RoutePlanFile>),
    /// A network plan.
    Network(Box<NetworkPlanFile>),
}

/// What `plan_folder` did: `plan.json`'s content, the folder and its files.
#[derive(Debug, Clone, Serialize)]
pub struct PlanOutcome {
    /// `plan.json`'s content.
    #[serde(flatten)]
    pub plan: PlanFiles,
    /// The folder written.
    pub out: PathBuf,
    /// The files written in it.
    pub files: Vec<&'static str>,
    /// Whole job time (s).
    pub elapsed_s: f64,
}

/// Route plan files.
const ROUTE_FILES: [&str; 9] = [
    "tags.csv",
    "tags.meta.json",
    "tags.geojson",
    "tags.kml",
    "tags.gpx",
    "plan.json",
    "profile.csv",
    "scenario.toml",
    "inputs.json",
];
/// Network plan files.
const NETWORK_FILES: [&str; 8] = [
    "tags.csv",
    "tags.meta.json",
    "tags.geojson",
    "tags.kml",
    "tags.gpx",
    "plan.json",
    "scenario.toml",
    "inputs.json",
];

/// Plans tags for the scenario `job.scenario`, validates the plan by Monte
/// Carlo and writes the plan folder: the installer files (`tags.csv`,
/// `.geojson`, `.kml`, `.gpx`), `plan.json` and, for route coverage,
/// `profile.csv` and the inputs `waymark report` needs.
pub fn plan_folder(job: &PlanJob, progress: &dyn Progress) -> Result<PlanOutcome> {
    let t0 = Instant::now();
    let scn = Scenario::load(job.scenario)?;
    check_out_dir(job.out_dir)?;
    check_inputs_outside_outputs(
        job.out_dir,
        &[PLAN_OUTPUTS, &["tags.meta.json", "inputs.json"]].concat(),
        &scenario_inputs(&scn),
    )?;
    let mut settings = PlannerSettings::from_scenario(&scn)?;
    if let Some(r) = job.runs {
        settings.validation_runs = r;
    }
    let seed = job.seed.unwrap_or(scn.seed());
    if settings.coverage == Coverage::Network {
        return network_plan_folder(&scn, &settings, job, seed, progress, t0);
    }
    let truth = TruthSource::new(&scn)?;
    let plan = route_plan(&scn, &truth, &settings, job.baseline, seed, progress)?;
    write_route_plan(job.scenario, job.out_dir, &scn, plan, t0)
}

/// A route plan on a loaded scenario and truth: placement, validation and,
/// with `baseline`, the uniform-spacing baseline. Returns the plan and its
/// planning time (s).
pub(super) fn route_plan(
    scn: &Scenario,
    truth: &TruthSource,
    settings: &PlannerSettings,
    baseline: bool,
    seed: u64,
    progress: &dyn Progress,
) -> Result<(Plan, f64)> {
    route_plan_runs(scn, truth, settings, baseline, seed, progress).map(|(p, t, _)| (p, t))
}

/// The tags a route plan's validation simulates: its new tags as written
/// to `tags.csv` (exported, formatted and read back, so the coordinates and
/// heights installers get, to the file's precision), each with the lane
/// width the plan found at its site (a property of the road, which the
/// file does not carry), and its installed tags as the plan keeps them, in
/// the plan's order. `waymark simulate --tags tags.csv` on the same
/// scenario simulates the same tags when the plan keeps no installed tags
/// and the lane widths do not change the RFID model's figures (road-surface
/// tags on map routes: the lateral error comes from the truth).
pub(super) fn written_tags(scn: &Scenario, plan: &Plan) -> Result<Vec<Tag>> {
    let (recs, meta) = plan.export(scn)?;
    let file = Path::new("tags.csv");
    let mut written = parse_tags_csv(file, &tags_csv(&recs, &meta))?.into_iter();
    let mut tags = plan.sim_tags();
    for (tag, planned) in tags.iter_mut().zip(&plan.tags) {
        if planned.existing {
            continue;
        }
        let w = written.next().filter(|w| w.id == tag.id).ok_or_else(|| {
            Error::format(file, format!("tag {} is not where the plan has it", tag.id))
        })?;
        *tag = Tag {
            lane_width_m: planned.lane_width_m,
            ..w
        };
    }
    if let Some(extra) = written.next() {
        return Err(Error::format(
            file,
            format!("tag {} is not in the plan", extra.id),
        ));
    }
    Ok(tags)
}

/// [`route_plan`], also giving the validation's runs (of the tags
/// [`written_tags`] gives), when it validated.
pub(super) fn route_plan_runs(
    scn: &Scenario,
    truth: &TruthSource,
    settings: &PlannerSettings,
    baseline: bool,
    seed: u64,
    progress: &dyn Progress,
) -> Result<(Plan, f64, Option<SimResult>)> {
    let t0 = Instant::now();
    super::limits::check_route_plan_size(scn, truth, settings)?;
    progress.note(&format!(
        "waymark plan: {}: covariance analysis along the route, then placement",
        scn.name()
    ));
    // A bar per planning stage (tag-free reaches, missed-tag check, ...): a
    // new one whenever the stage or its size changes, so its ETA is its own.
    let current: std::sync::Mutex<Option<(PlanStage, usize)>> = std::sync::Mutex::new(None);
    let tick = |stage: PlanStage, done: usize, total: usize| {
        let mut cur = current.lock().unwrap_or_else(|e| e.into_inner());
        if *cur != Some((stage, total)) {
            if cur.is_some() {
                progress.finish();
            }
            progress.start(stage.label(), total as u64);
            *cur = Some((stage, total));
        }
        progress.set(done as u64, total as u64);
    };
    let planned = plan_with_stages(scn, truth, settings, seed, false, Some(&tick));
    if current.lock().unwrap_or_else(|e| e.into_inner()).is_some() {
        progress.finish();
    }
    let mut p = planned?;
    if p.predicted_max_bound95_missed_m.is_none() {
        p.predicted_max_bound95_missed_m = p.missed_bound(scn, truth);
    }
    let t_plan = t0.elapsed().as_secs_f64();
    let mut runs = None;
    if settings.validation_runs > 0 {
        progress.note(&format!(
            "waymark plan: validating {} tag(s) by {} Monte Carlo run(s)",
            p.tag_count(),
            settings.validation_runs
        ));
        // A diverged plan is named as such before its tags are written.
        super::finite::check_plan(&scn.path, scn, &p)?;
        let tags = written_tags(scn, &p)?;
        let (v, res) = validate_plan_on(scn, truth, &p, &tags, settings.validation_runs, seed)?;
        p.validation = Some(v);
        runs = Some(res);
    }
    if baseline {
        progress.note("waymark plan: searching the uniform-spacing baseline");
        p.uniform_baseline = uniform_baseline(
            scn,
            truth,
            settings,
            settings.validation_runs.max(1),
            seed,
            0.99,
        )?;
    }
    Ok((p, t_plan, runs))
}

/// Writes a route plan's folder.
pub(super) fn write_route_plan(
    scenario: &Path,
    out_dir: &Path,
    scn: &Scenario,
    (plan, plan_time_s): (Plan, f64),
    t0: Instant,
) -> Result<PlanOutcome> {
    super::finite::check_plan(scenario, scn, &plan)?;
    let (recs, meta) = plan.export(scn)?;
    clear_outputs(out_dir, PLAN_OUTPUTS)?;
    write_tag_files(out_dir, &recs, &meta)?;
    write_atomic(
        &out_dir.join("profile.csv"),
        plan_profile_csv(&plan.profile_with_tags, &plan.profile_without_tags).as_bytes(),
    )?;
    let file = RoutePlanFile {
        tag_count: plan.tag_count(),
        existing_tags_kept: plan.existing_count(),
        tags_by_mounting: plan.by_mounting(),
        waymark_version: env!("CARGO_PKG_VERSION"),
        plan_time_s,
        plan,
        tag_files: meta,
    };
    write_json(&out_dir.join("plan.json"), &file)?;
    // What `waymark report` needs to draw the map later.
    keep_inputs(scenario, out_dir, Some(&out_dir.join("tags.csv")))?;
    Ok(PlanOutcome {
        plan: PlanFiles::Route(Box::new(file)),
        out: out_dir.to_path_buf(),
        files: ROUTE_FILES.to_vec(),
        elapsed_s: t0.elapsed().as_secs_f64(),
    })
}

/// Network coverage: plan on the loaded map, validate on sampled paths of
/// the same map, write the folder.
fn network_plan_folder(
    scn: &Scenario,
    settings: &PlannerSettings,
    job: &PlanJob,
    seed: u64,
    progress: &dyn Progress,
    t0: Instant,
) -> Result<PlanOutcome> {
    if job.baseline && settings.validation_runs == 0 {
        return Err(Error::InvalidParameter(
            "--baseline: a network plan's baseline is its validation driven without the \
             planned tags, so it needs validation runs (--runs 0 was given)"
                .into(),
        ));
    }
    progress.note(&format!(
        "waymark plan: {}: network coverage (reach from the filter, then placement on every directed road)",
        scn.name()
    ));
    // The map, then the plan (which checks its candidate sites against
    // their limit first).
    let t_load = Instant::now();
    let net = std::sync::Arc::new(scenario_network(scn)?);
    let load_ms = t_load.elapsed().as_secs_f64() * 1e3;
    let mut plan = plan_network_on(scn, settings, &net)?;
    plan.timings_ms.insert("load".into(), load_ms);
    let plan_time_s = t0.elapsed().as_secs_f64();
    // Terrain heights first: the validation drives the same terrain and
    // its tag fixes carry these heights.
    let terrain = terrain_heights(scn, &net, &mut plan)?;
    if settings.validation_runs > 0 {
        progress.note(&format!(
            "waymark plan: validating {} tag(s) by {} Monte Carlo run(s) on fresh chains of trips",
            plan.tag_count(),
            settings.validation_runs
        ));
        plan.validation = Some(validate_network_plan(
            scn,
            &net,
            &plan,
            settings.validation_runs,
            seed,
            job.baseline,
        )?);
    }
    super::finite::check_network_plan(job.scenario, scn, &plan)?;
    let (recs, mut meta) = plan.export(scn)?;
    if let Some(why) = terrain {
        meta.heights_known = true;
        meta.parameters.insert("height_m".into(), why);
    }
    clear_outputs(job.out_dir, PLAN_OUTPUTS)?;
    write_tag_files(job.out_dir, &recs, &meta)?;
    let mut files = NETWORK_FILES.to_vec();
    if !plan.edge_coverage.is_empty() {
        write_atomic(
            &job.out_dir.join("coverage.geojson"),
            crate::planner::network::coverage_geojson(&plan.edge_coverage, &net).as_bytes(),
        )?;
        files.push("coverage.geojson");
    }
    let file = NetworkPlanFile {
        tag_count: plan.tag_count(),
        tags_by_mounting: plan.by_mounting(),
        waymark_version: env!("CARGO_PKG_VERSION"),
        plan_time_s,
        plan,
        tag_files: meta,
    };
    write_json(&job.out_dir.join("plan.json"), &file)?;
    // What `waymark report` needs to draw the area later.
    keep_inputs(
        job.scenario,
        job.out_dir,
        Some(&job.out_dir.join("tags.csv")),
    )?;
    Ok(PlanOutcome {
        plan: PlanFiles::Network(Box::new(file)),
        out: job.out_dir.to_path_buf(),
        files,
        elapsed_s: t0.elapsed().as_secs_f64(),
    })
}

/// `[map] elevation` on an area plan: every new tag's height is the
/// road's at the tag's section and offset (the DEM's there, tunnels and
/// bridges interpolated between their ends: [`NetworkHeights`]); returns
/// what the metadata says of it, `None` without an elevation model. The
/// plan's validation runs after, on the same terrain (its drives follow
/// the elevation model), so tags and truth agree in height, which the
/// filter's tag fixes need; the planner's reach analysis drives level
/// roads.
fn terrain_heights(
    scn: &Scenario,
    net: &crate::network::Network,
    plan: &mut NetworkPlan,
) -> Result<Option<String>> {
    if scn.elevation.is_empty() {
        return Ok(None);
    }
    let dem = Dem::open(&scn.elevation)?;
    let heights = NetworkHeights::new(net, &dem)?;
    for t in plan.tags.iter_mut().filter(|t| !t.existing) {
        let road_offset = net
            .section_segments(t.section)
            .first()
            .map_or(0.0, |s| s.road_offset_m);
        t.height_m = heights.at(
            t.section,
            t.chainage_m - road_offset,
            [t.centre_lat, t.centre_lon],
        )?;
    }
    Ok(Some(format!(
        "the terrain's, from the elevation model {} (bilinear at the road's centre line \
         beside each tag; tunnels and bridges interpolated between their ends); the plan's \
         validation drove the same terrain",
        dem.describe()
    )))
}

/// The installer files, in a folder created if missing.
fn write_tag_files(out_dir: &Path, recs: &[TagRecord], meta: &ExportMetadata) -> Result<()> {
    std::fs::create_dir_all(out_dir).map_err(|e| Error::io(out_dir, e))?;
    write_atomic(&out_dir.join("tags.csv"), tags_csv(recs, meta).as_bytes())?;
    write_atomic(
        &out_dir.join("tags.meta.json"),
        tags_meta_json(meta).as_bytes(),
    )?;
    write_atomic(
        &out_dir.join("tags.geojson"),
        tags_geojson(recs, meta).as_bytes(),
    )?;
    write_atomic(&out_dir.join("tags.kml"), tags_kml(recs, meta).as_bytes())?;
    write_atomic(&out_dir.join("tags.gpx"), tags_gpx(recs, meta).as_bytes())
}

/// Pretty JSON with its keys sorted (as every JSON file Waymark writes).
pub(super) fn write_json(path: &Path, value: &impl Serialize) -> Result<()> {
    let text = serde_json::to_value(value)
        .and_then(|v| serde_json::to_string_pretty(&v))
        .map_err(|e| Error::format(path, format!("cannot serialize: {e}")))?;
    write_atomic(path, text.as_bytes())
}
