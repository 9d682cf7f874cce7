//! `waymark demo`: the main job on the bundled map and scenario.

use super::inputs::check_out_dir;
use super::plan::{route_plan_runs, write_route_plan, written_tags, PlanOutcome};
use super::progress::Progress;
use super::simulate::{first_runs, write_simulation, SimulateJob, SimulateOutcome};
use crate::error::Result;
use crate::planner::PlannerSettings;
use crate::report::{write_report_on, ReportFiles};
use crate::scenario::Scenario;
use crate::sim::{simulate_with, TruthSource};
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
/// tags for its route and validates them with the tags as written to
/// `tags.csv` (what installers get), takes the simulation for the report
/// from the validation's first `DEMO_SIMULATION_RUNS` runs (the same
/// seed, so the same runs; simulated when the validation has fewer), and
/// writes the HTML report, all into `out_dir`. The scenario, its map and
/// route are loaded once, for the plan, the simulation and the report's
/// map. On `scenarios/demo.toml` the simulation's files are those of
/// `waymark simulate scenarios/demo.toml --tags OUT/tags.csv --runs 20`
/// (a test checks it).
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
    let (plan, plan_time_s, runs) =
        route_plan_runs(&scn, &truth, &settings, false, seed, progress)?;
    // The simulation's tags: the planned tags as written to tags.csv (the
    // validation's tags, `written_tags`).
    let tags = written_tags(&scn, &plan)?;
    let plan = write_route_plan(scenario, out_dir, &scn, (plan, plan_time_s), t0)?;
    let tags_file = out_dir.join("tags.csv");
    let job = SimulateJob {
        scenario,
        tags: Some(&tags_file),
        runs: DEMO_SIMULATION_RUNS,
        seed: None,
        out_dir,
    };
    let t_sim = Instant::now();
    let result = match runs {
        // The validation simulated these tags with the same seed: its first
        // runs are the simulation's, not run again.
        Some(res) if res.runs.len() as u64 >= DEMO_SIMULATION_RUNS => {
            progress.note(&format!(
                "waymark demo: the validation's first {DEMO_SIMULATION_RUNS} runs with the planned tags, for the report"
            ));
            first_runs(&scn, seed, res, DEMO_SIMULATION_RUNS)
        }
        _ => {
            progress.note(&format!(
                "waymark demo: simulating the route with the planned tags ({DEMO_SIMULATION_RUNS} runs) for the report"
            ));
            simulate_with(&scn, &truth, &tags, DEMO_SIMULATION_RUNS, seed, None)?
        }
    };
    let simulation = write_simulation(&job, &scn, result, t_sim)?;
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::workflow::{simulate_folder, Silent};

    /// The demo's simulation (the validation's first runs) is the
    /// simulation `waymark simulate scenarios/demo.toml --tags OUT/tags.csv
    /// --runs 20` runs: its files are the same, byte for byte.
    #[test]
    fn demo_simulation_is_the_simulation_of_the_written_tags() {
        let scenario = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenarios/demo.toml");
        let dir = tempfile::tempdir().expect("temp dir");
        let (demo, sim) = (dir.path().join("demo"), dir.path().join("sim"));
        let o = demo_folder(&scenario, &demo, &Silent).expect("demo");
        let v = match &o.plan.plan {
            super::super::plan::PlanFiles::Route(f) => f.plan.validation.clone(),
            _ => None,
        };
        assert!(v.is_some_and(|v| v.runs > DEMO_SIMULATION_RUNS));
        let tags = demo.join("tags.csv");
        let job = SimulateJob {
            scenario: &scenario,
            tags: Some(&tags),
            runs: DEMO_SIMULATION_RUNS,
            seed: None,
            out_dir: &sim,
        };
        let s = simulate_folder(&job, &Silent).expect("simulate");
        assert_eq!(s.result.runs.len() as u64, DEMO_SIMULATION_RUNS);
        let mut files = s.files.clone();
        files.retain(|f| *f != "inputs.json" && *f != "scenario.toml");
        assert!(files.len() >= 5, "{files:?}");
        for f in files {
            let a = std::fs::read(demo.join(f)).expect("demo file");
            let b = std::fs::read(sim.join(f)).expect("simulation file");
            assert!(a == b, "{f} differs");
        }
    }
}
