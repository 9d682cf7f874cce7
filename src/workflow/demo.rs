//! `waymark demo`: the main job on the bundled map and scenario.

use super::inputs::check_out_dir;
use super::plan::{route_plan, write_route_plan, PlanOutcome};
use super::progress::Progress;
use super::simulate::{simulate_loaded, SimulateJob, SimulateOutcome};
use crate::error::Result;
use crate::planner::PlannerSettings;
use crate::report::{write_report_on, ReportFiles};
use crate::scenario::Scenario;
use crate::sim::TruthSource;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Runs simulated with the planned tags, for the report.
pub const DEMO_SIMULATION_RUNS: u64 = 20;

/// What `demo_folder` did.
#[derive(Debug, Clone)]
pub struct DemoOutcome {
    /// The plan (with its validation).
    pub plan: PlanOutcome,
    /// The simulation with the planned tags.
    pub simulation: SimulateOutcome,
    /// The report.
    pub report: ReportFiles,
    /// The folder written.
    pub out: PathBuf,
    /// Every file in it.
    pub files: Vec<&'static str>,
    /// Whole job time (s).
    pub elapsed_s: f64,
}

/// The main job on `scenario` (the bundled `scenarios/demo.toml`): plans
/// tags for its route and validates them, simulates the route with the
/// planned tags as written to `tags.csv` (what installers get), and writes
/// the HTML report, all into `out_dir`. The scenario, its map and route are
/// loaded once, for the plan, the simulation and the report's map.
pub fn demo_folder(
    scenario: &Path,
    out_dir: &Path,
    progress: &dyn Progress,
) -> Result<DemoOutcome> {
    let t0 = Instant::now();
    let scn = Scenario::load(scenario)?;
    check_out_dir(out_dir)?;
    let truth = TruthSource::new(&scn)?;
    let settings = PlannerSettings::from_scenario(&scn)?;
    let seed = scn.seed();
    let plan = route_plan(&scn, &truth, &settings, false, seed, progress)?;
    let plan = write_route_plan(scenario, out_dir, &scn, plan, t0)?;
    progress.note(&format!(
        "waymark demo: simulating the route with the planned tags ({DEMO_SIMULATION_RUNS} runs) for the report"
    ));
    let tags = out_dir.join("tags.csv");
    let job = SimulateJob {
        scenario,
        tags: Some(&tags),
        runs: DEMO_SIMULATION_RUNS,
        seed: None,
        out_dir,
    };
    let simulation = simulate_loaded(&job, &scn, &truth, progress, Instant::now())?;
    let loaded = truth
        .network()
        .zip(truth.route())
        .map(|(net, route)| (&**net, route));
    let report = write_report_on(out_dir, loaded)?;
    Ok(DemoOutcome {
        plan,
        simulation,
        report,
        out: out_dir.to_path_buf(),
        files: vec![
            "tags.csv",
            "tags.geojson",
            "tags.kml",
            "tags.gpx",
            "plan.json",
            "profile.csv",
            "errors.csv",
            "summary.json",
            "tag_passes.csv",
            "scenario.toml",
            "inputs.json",
            "report.html",
        ],
        elapsed_s: t0.elapsed().as_secs_f64(),
    })
}
