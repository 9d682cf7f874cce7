//! The `waymark` command line: a thin layer over the library.

use anyhow::{Context, Result};
use clap::{Parser, Subcommand};
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;
use waymark::network::{LoadOptions, Network, DEFAULT_NODE_TOLERANCE_M};

/// Plans RFID tag infrastructure for vehicles navigating without satellite
/// positioning, and evaluates their position accuracy along routes.
#[derive(Parser)]
#[command(name = "waymark", version, about, long_about = None)]
#[command(after_help = "Examples:\n  waymark demo\n  \
    waymark plan scenarios/demo.toml --out /tmp/plan && waymark report /tmp/plan\n  \
    waymark simulate scenarios/helsinki-route-dr.toml --json -q --out /tmp/hel\n\n\
    Output: results on stdout (one JSON object with --json); progress, notes and \
    logs (-v) on stderr; progress bars only when stderr is a terminal.\n\
    Exit codes: 0 success, 1 bad input or failure, 2 bad command line.")]
struct Cli {
    /// Print nothing but errors (and the --json object): no progress, notes or text summaries.
    #[arg(short, long, global = true, conflicts_with = "verbose")]
    quiet: bool,
    /// Log to stderr: -v info, -vv debug.
    #[arg(short, long, global = true, action = clap::ArgAction::Count)]
    verbose: u8,
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Runs the main job on the bundled map and scenario: plans tags for a 20 m requirement, validates them, writes the installer files and an HTML report.
    #[command(
        after_help = "Examples:\n  waymark demo\n  waymark demo --out /tmp/waymark-demo\n  \
        waymark demo --json -q --out /tmp/waymark-demo"
    )]
    Demo {
        /// Output folder.
        #[arg(long, default_value = "waymark-demo")]
        out: PathBuf,
        /// Print one JSON object (files, plan and simulation figures) on stdout.
        #[arg(long)]
        json: bool,
    },
    /// Road network commands.
    #[command(
        subcommand,
        after_help = "Example:\n  waymark network inspect maps/helsinki.osm.pbf --json"
    )]
    Network(NetworkCommand),
    /// Writes DIR/report.html (self-contained: inline SVG plots and map, no network) and PNG plots for a simulate and/or plan output folder.
    #[command(
        after_help = "Examples:\n  waymark simulate scenarios/helsinki-route-dr.toml --out /tmp/hel\n  \
        waymark report /tmp/hel\n  \
        waymark plan scenarios/demo.toml --out /tmp/plan\n  \
        waymark report /tmp/plan --json"
    )]
    Report {
        /// The output folder of `waymark simulate` or `waymark plan`.
        dir: PathBuf,
        /// Print one JSON object (the files written) on stdout.
        #[arg(long)]
        json: bool,
    },
    /// Matches positions (TRACK.csv) to the road network; writes MATCHED.csv.
    #[command(
        after_help = "TRACK.csv: header t_s,lat,lon and optionally heading_deg,speed_mps,track_id.\n\
        TRUTH.csv (for --truth): header road_id and optionally length_m.\n\
        Examples:\n  waymark match --map maps/helsinki.osm.pbf --track track.csv --out matched.csv\n  \
        waymark match --map maps/helsinki.osm.pbf --track track.csv --method incremental --truth truth.csv"
    )]
    Match {
        /// The map: .osm.pbf, .osm (XML), .geojson or .shp.
        #[arg(long)]
        map: PathBuf,
        /// The positions to match (CSV).
        #[arg(long, value_name = "TRACK.csv")]
        track: PathBuf,
        /// Output file.
        #[arg(long, value_name = "MATCHED.csv", default_value = "matched.csv")]
        out: PathBuf,
        /// Matcher.
        #[arg(long, value_enum, default_value = "hmm")]
        method: MatchMethod,
        /// Scores the match against the roads actually driven (CSV with road_id[,length_m]).
        #[arg(long, value_name = "TRUTH.csv")]
        truth: Option<PathBuf>,
        /// Print one JSON object (counts, breaks, timings, scores) on stdout.
        #[arg(long)]
        json: bool,
    },
    /// Simulates a scenario: truth, sensors and navigator; writes errors.csv and summary.json.
    #[command(
        after_help = "Examples:\n  waymark simulate scenarios/schuler-accel-bias.toml --out /tmp/schuler\n  \
        waymark simulate scenarios/dr3d-paper.toml --runs 10 --seed 7 --out /tmp/dr3d\n  \
        waymark simulate scenarios/nees-consistency.toml --runs 100 --out /tmp/nees\n  \
        waymark simulate drive.toml --tags tags.csv --runs 20 --out /tmp/drive\n  \
        waymark simulate scenarios/dr-straight-10km.toml --json -q --out /tmp/dr"
    )]
    Simulate {
        /// The scenario file (TOML).
        scenario: PathBuf,
        /// Existing tags (CSV: tag_id,lat,lon,mounting required; height_m optional); integrated mode.
        #[arg(long, value_name = "TAGS.csv")]
        tags: Option<PathBuf>,
        /// Monte Carlo runs.
        #[arg(long, default_value_t = 1)]
        runs: u64,
        /// Base seed (default: the scenario's `seed`, else 1).
        #[arg(long)]
        seed: Option<u64>,
        /// Output folder.
        #[arg(long, default_value = "waymark-simulate")]
        out: PathBuf,
        /// Print one JSON object (summary.json's figures less the profile, and the files) on stdout.
        #[arg(long)]
        json: bool,
    },
    /// Plans RFID tags for a scenario's route: the fewest tags keeping the predicted 95 % horizontal error within requirement_m; validates by Monte Carlo; writes tags.csv/.geojson/.kml/.gpx, plan.json, profile.csv and, for `waymark report`, scenario.toml and inputs.json.
    #[command(
        after_help = "Examples:\n  waymark plan scenarios/helsinki-plan-tactical.toml --out /tmp/plan\n  \
        waymark plan drive.toml --runs 20 --seed 3 --out /tmp/drive-plan\n  \
        waymark plan scenarios/demo.toml --baseline --json --out /tmp/demo-plan"
    )]
    Plan {
        /// The scenario file (TOML) with requirement_m and an integrated navigator.
        scenario: PathBuf,
        /// Output folder.
        #[arg(long, default_value = "waymark-plan")]
        out: PathBuf,
        /// Validation runs (default: planner.validation_runs, else 100; 0 skips validation).
        #[arg(long)]
        runs: Option<u64>,
        /// Base seed of the validation (default: the scenario's `seed`, else 1).
        #[arg(long)]
        seed: Option<u64>,
        /// Also find the uniform-spacing baseline: the largest spacing that passes the plan's covariance check (any k consecutive tags missed) and whose validation keeps ≥ 99 % of distance within the requirement.
        #[arg(long)]
        baseline: bool,
        /// Print one JSON object (plan.json's content and the files) on stdout.
        #[arg(long)]
        json: bool,
    },
}

#[derive(Clone, Copy, clap::ValueEnum)]
enum MatchMethod {
    /// The paper's incremental matcher (grid, tracking, topology).
    Incremental,
    /// Hidden-Markov matcher (Viterbi, network distances, bounded lag).
    Hmm,
}

#[derive(Subcommand)]
enum NetworkCommand {
    /// Loads a map and prints counts, length, components, grid occupancy, defects and timings.
    #[command(
        after_help = "Examples:\n  waymark network inspect maps/helsinki.osm.pbf\n  \
        waymark network inspect maps/gothenburg-roads.geojson --json\n  \
        waymark network inspect map.osm --defects defects.geojson"
    )]
    Inspect {
        /// The map: .osm.pbf, .osm (XML) or .geojson (format follows the content).
        map: PathBuf,
        /// Print one JSON object instead of text.
        #[arg(long)]
        json: bool,
        /// Also load highway=track.
        #[arg(long)]
        tracks: bool,
        /// Grid size N (a power of two up to 2048); chosen from the map's size by default.
        #[arg(long)]
        grid_n: Option<u32>,
        /// Distance below which two unjoined nodes are reported (m).
        #[arg(long, default_value_t = DEFAULT_NODE_TOLERANCE_M)]
        tolerance: f64,
        /// Write every defect as a GeoJSON point to this file.
        #[arg(long, value_name = "FILE")]
        defects: Option<PathBuf>,
    },
}

/// Where a command's output goes: results on stdout (text, or one JSON
/// object with `--json`, the text then going to stderr); progress and notes
/// on stderr; `--quiet` keeps only errors and the JSON object.
#[derive(Clone, Copy)]
struct Out {
    quiet: bool,
    json: bool,
}

impl Out {
    /// A line of the human-readable result.
    fn text(&self, args: std::fmt::Arguments) {
        use std::io::Write as _;
        if self.quiet {
        } else if self.json {
            let _ = writeln!(std::io::stderr(), "{args}");
        } else {
            // A closed pipe (e.g. `| head`) is not an error.
            let _ = writeln!(std::io::stdout(), "{args}");
        }
    }

    /// The human-readable result without a trailing newline.
    fn text_raw(&self, args: std::fmt::Arguments) {
        use std::io::Write as _;
        if self.quiet {
        } else if self.json {
            let _ = write!(std::io::stderr(), "{args}");
        } else {
            let _ = write!(std::io::stdout(), "{args}");
        }
    }

    /// A progress note or a summary meant for people, on stderr.
    fn note(&self, args: std::fmt::Arguments) {
        use std::io::Write as _;
        if !self.quiet {
            let _ = writeln!(std::io::stderr(), "{args}");
        }
    }

    /// A progress bar on stderr: hidden when stderr is not a terminal or with --quiet.
    fn bar(&self, len: u64, template: &str) -> indicatif::ProgressBar {
        if self.quiet || !std::io::IsTerminal::is_terminal(&std::io::stderr()) {
            return indicatif::ProgressBar::hidden();
        }
        let b = indicatif::ProgressBar::new(len);
        b.set_style(
            indicatif::ProgressStyle::with_template(template)
                .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        b
    }
}

/// `text!(out, ...)`: a line of the result.
macro_rules! text {
    ($out:expr, $($t:tt)*) => { $out.text(format_args!($($t)*)) };
}

/// `note!(out, ...)`: a note on stderr.
macro_rules! note {
    ($out:expr, $($t:tt)*) => { $out.note(format_args!($($t)*)) };
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    init_logging(cli.verbose);
    match run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("waymark: error: {e:#}");
            ExitCode::from(1)
        }
    }
}

/// Logging (crate `tracing`) to stderr: off by default, -v info, -vv debug.
fn init_logging(verbose: u8) {
    let level = match verbose {
        0 => return,
        1 => tracing::Level::INFO,
        _ => tracing::Level::DEBUG,
    };
    tracing_subscriber::fmt()
        .with_max_level(level)
        .with_writer(std::io::stderr)
        .with_ansi(std::io::IsTerminal::is_terminal(&std::io::stderr()))
        .init();
}

/// Runs the command; each returns its `--json` object (`Null` when it has
/// printed its own).
fn run(cli: Cli) -> Result<()> {
    let quiet = cli.quiet;
    let out = |json: bool| Out { quiet, json };
    let (json, value) = match cli.command {
        Command::Demo { out: dir, json } => (json, demo(&dir, out(json))?),
        Command::Simulate {
            scenario,
            tags,
            runs,
            seed,
            out: dir,
            json,
        } => (
            json,
            simulate(&scenario, tags.as_deref(), runs, seed, &dir, out(json))?,
        ),
        Command::Report { dir, json } => (json, report(&dir, out(json))?),
        Command::Plan {
            scenario,
            out: dir,
            runs,
            seed,
            baseline,
            json,
        } => (
            json,
            plan(&scenario, &dir, runs, seed, baseline, out(json))?,
        ),
        Command::Match {
            map,
            track,
            out: file,
            method,
            truth,
            json,
        } => (
            json,
            match_track(&map, &track, &file, method, truth.as_deref(), out(json))?,
        ),
        Command::Network(NetworkCommand::Inspect {
            map,
            json,
            tracks,
            grid_n,
            tolerance,
            defects,
        }) => {
            let options = LoadOptions {
                include_tracks: tracks,
                grid_n,
            };
            (
                json,
                inspect(&map, options, tolerance, defects.as_deref(), out(json))?,
            )
        }
    };
    if json && !value.is_null() {
        use std::io::Write as _;
        let _ = writeln!(
            std::io::stdout(),
            "{}",
            serde_json::to_string_pretty(&value)?
        );
    }
    Ok(())
}

fn plan(
    scenario: &Path,
    out_dir: &Path,
    runs: Option<u64>,
    seed: Option<u64>,
    baseline: bool,
    out: Out,
) -> Result<serde_json::Value> {
    use waymark::planner;
    let t0 = Instant::now();
    let scn = waymark::sim::Scenario::load(scenario)?;
    let seed = seed.unwrap_or(scn.seed());
    let mut settings = planner::PlannerSettings::from_scenario(&scn)?;
    if let Some(r) = runs {
        settings.validation_runs = r;
    }
    if settings.coverage == planner::Coverage::Network {
        return write_network_plan(&scn, &settings, out_dir, seed, baseline, out);
    }
    let truth = waymark::sim::TruthSource::new(&scn)?;
    note!(
        out,
        "waymark plan: {}: covariance analysis along the route, then placement",
        scn.name()
    );
    let bar = out.bar(
        0,
        "{bar:40} {pos}/{len} candidate sites, {elapsed} (eta {eta})",
    );
    let tick = |done: usize, total: usize| {
        bar.set_length(total as u64);
        bar.set_position(done as u64);
    };
    let mut p = planner::plan_with_progress(&scn, &truth, &settings, seed, false, Some(&tick))?;
    bar.finish_and_clear();
    let t_plan = t0.elapsed().as_secs_f64();
    if settings.validation_runs > 0 {
        note!(
            out,
            "waymark plan: validating {} tag(s) by {} Monte Carlo run(s)",
            p.tag_count(),
            settings.validation_runs
        );
        p.validation = Some(planner::validate_plan(
            &scn,
            &truth,
            &p,
            settings.validation_runs,
            seed,
        )?);
    }
    if baseline {
        note!(out, "waymark plan: searching the uniform-spacing baseline");
        p.uniform_baseline = planner::uniform_baseline(
            &scn,
            &truth,
            &settings,
            settings.validation_runs.max(1),
            seed,
            0.99,
        )?;
    }
    let (recs, meta) = p.export(&scn)?;
    std::fs::create_dir_all(out_dir).with_context(|| format!("creating {}", out_dir.display()))?;
    use waymark::export::{
        plan_profile_csv, tags_csv, tags_geojson, tags_gpx, tags_kml, write_atomic,
    };
    write_atomic(&out_dir.join("tags.csv"), tags_csv(&recs, &meta).as_bytes())?;
    write_atomic(
        &out_dir.join("tags.geojson"),
        tags_geojson(&recs, &meta).as_bytes(),
    )?;
    write_atomic(&out_dir.join("tags.kml"), tags_kml(&recs, &meta).as_bytes())?;
    write_atomic(&out_dir.join("tags.gpx"), tags_gpx(&recs, &meta).as_bytes())?;
    write_atomic(
        &out_dir.join("profile.csv"),
        plan_profile_csv(&p.profile_with_tags, &p.profile_without_tags).as_bytes(),
    )?;
    let mut json = serde_json::to_value(&p)?;
    json["tag_count"] = serde_json::json!(p.tag_count());
    json["existing_tags_kept"] = serde_json::json!(p.existing_count());
    json["tags_by_mounting"] = serde_json::json!(p.by_mounting());
    json["waymark_version"] = serde_json::json!(env!("CARGO_PKG_VERSION"));
    json["plan_time_s"] = serde_json::json!(t_plan);
    write_atomic(
        &out_dir.join("plan.json"),
        serde_json::to_string_pretty(&json)?.as_bytes(),
    )?;
    // What `waymark report` needs to draw the map later.
    keep_inputs(scenario, out_dir, Some(&out_dir.join("tags.csv")))?;
    let by: Vec<String> = p
        .by_mounting()
        .iter()
        .map(|(k, v)| format!("{v} {k}"))
        .collect();
    text!(
        out,
        "{}: {} new tag(s) ({}){} over {:.1} km, total cost {:.1}, max gap {:.0} m; requirement {} m with {} missed read(s) tolerated; predicted max 95 % bound {:.2} m (all read); lower bound {} new tag(s){}; method: {}",
        p.scenario,
        p.tag_count(),
        if by.is_empty() { "none".to_string() } else { by.join(", ") },
        if p.existing_count() > 0 {
            format!(" + {} installed", p.existing_count())
        } else {
            String::new()
        },
        p.route_length_m / 1000.0,
        p.total_cost,
        p.max_gap_m,
        p.requirement_m,
        p.tolerate_missed_reads,
        p.predicted_max_bound95_m,
        p.lower_bound,
        if p.optimal { " (plan proven minimal)" } else { "" },
        p.method
    );
    if let Some(v) = &p.validation {
        text!(
            out,
            "validation: {} run(s), seed {}: {:.2} % of distance within {} m; max horizontal error {:.2} m (run {}, t = {:.0} s, {:.0} m along the route)",
            v.runs,
            v.seed,
            100.0 * v.fraction_within_requirement,
            p.requirement_m,
            v.max_horizontal_error_m,
            v.worst_run,
            v.worst_t_s,
            v.worst_distance_m
        );
    }
    if baseline {
        match &p.uniform_baseline {
            Some(b) => text!(
                out,
                "uniform baseline (same standard: covariance check with {} missed read(s) tolerated, then Monte Carlo): {} tag(s) every {:.0} m keep {:.2} % of distance within {} m ({} run(s)); plan uses {}{}",
                b.tolerate_missed_reads,
                b.tag_count,
                b.spacing_m,
                100.0 * b.validation.fraction_within_requirement,
                p.requirement_m,
                b.validation.runs,
                p.tag_count(),
                if b.tag_count > 0 {
                    format!(
                        " ({:+.0} %)",
                        100.0 * (p.tag_count() as f64 - b.tag_count as f64) / b.tag_count as f64
                    )
                } else {
                    String::new()
                }
            ),
            None => text!(
                out,
                "uniform baseline: none passes, even at the candidate spacing"
            ),
        }
    }
    let elapsed = t0.elapsed().as_secs_f64();
    text!(
        out,
        "wrote {}/tags.csv, tags.geojson, tags.kml, tags.gpx, plan.json, profile.csv in {:.1} s",
        out_dir.display(),
        elapsed
    );
    json["out"] = serde_json::json!(out_dir.display().to_string());
    json["files"] = serde_json::json!([
        "tags.csv",
        "tags.geojson",
        "tags.kml",
        "tags.gpx",
        "plan.json",
        "profile.csv",
        "scenario.toml",
        "inputs.json"
    ]);
    json["elapsed_s"] = serde_json::json!(elapsed);
    Ok(json)
}

/// Keeps a copy of the scenario (`scenario.toml`) and where it and the tag
/// file were (`inputs.json`) in an output folder, for `waymark report`.
fn keep_inputs(scenario: &Path, out_dir: &Path, tags: Option<&Path>) -> Result<()> {
    let text =
        std::fs::read(scenario).with_context(|| format!("{}: cannot read", scenario.display()))?;
    waymark::export::write_atomic(&out_dir.join("scenario.toml"), &text)?;
    waymark::report::write_inputs(out_dir, scenario, tags)?;
    Ok(())
}

/// `waymark plan` for `coverage = "network"`: plan, validate, write the files.
fn write_network_plan(
    scn: &waymark::sim::Scenario,
    settings: &waymark::planner::PlannerSettings,
    out_dir: &Path,
    seed: u64,
    baseline: bool,
    out: Out,
) -> Result<serde_json::Value> {
    use waymark::export::{tags_csv, tags_geojson, tags_gpx, tags_kml, write_atomic};
    use waymark::planner::network;
    if baseline {
        anyhow::bail!("--baseline compares with uniform spacing along a route; it does not apply to coverage = \"network\"");
    }
    let t0 = Instant::now();
    note!(
        out,
        "waymark plan: {}: network coverage (reach from the filter, then placement on every directed road)",
        scn.name()
    );
    let (net, mut p) = network::plan_network_loaded(scn, settings)?;
    let t_plan = t0.elapsed().as_secs_f64();
    if settings.validation_runs > 0 {
        note!(
            out,
            "waymark plan: validating {} tag(s) by {} Monte Carlo run(s) on sampled paths",
            p.tag_count(),
            settings.validation_runs
        );
        p.validation = Some(network::validate_network_plan(
            scn,
            &net,
            &p,
            settings.validation_runs,
            seed,
        )?);
    }
    let (recs, meta) = p.export(scn)?;
    std::fs::create_dir_all(out_dir).with_context(|| format!("creating {}", out_dir.display()))?;
    write_atomic(&out_dir.join("tags.csv"), tags_csv(&recs, &meta).as_bytes())?;
    write_atomic(
        &out_dir.join("tags.geojson"),
        tags_geojson(&recs, &meta).as_bytes(),
    )?;
    write_atomic(&out_dir.join("tags.kml"), tags_kml(&recs, &meta).as_bytes())?;
    write_atomic(&out_dir.join("tags.gpx"), tags_gpx(&recs, &meta).as_bytes())?;
    let mut json = serde_json::to_value(&p)?;
    json["tag_count"] = serde_json::json!(p.tag_count());
    json["tags_by_mounting"] = serde_json::json!(p.by_mounting());
    json["waymark_version"] = serde_json::json!(env!("CARGO_PKG_VERSION"));
    json["plan_time_s"] = serde_json::json!(t_plan);
    write_atomic(
        &out_dir.join("plan.json"),
        serde_json::to_string_pretty(&json)?.as_bytes(),
    )?;
    let by: Vec<String> = p
        .by_mounting()
        .iter()
        .map(|(k, v)| format!("{v} {k}"))
        .collect();
    text!(
        out,
        "{}: network coverage: {} new tag(s) ({}){} on {} directed road sections ({:.1} km, {} candidates), total cost {:.1}; \
         requirement {} m with {} missed read(s) tolerated; reach R = {:.0}–{:.0} m by speed class (slowest: steady {:.0} m, start {:.0} m); \
         method: {}; lower bound {} tag(s); verified: {}",
        p.scenario,
        p.tag_count(),
        if by.is_empty() { "none".to_string() } else { by.join(", ") },
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
        if p.verified { "no walk exceeds the error budget with ≤ k tags" } else { "NO" },
    );
    if let Some(v) = &p.validation {
        text!(
        out,
            "validation: {} run(s) on {} sampled path(s) ({:.1} km), seed {}: {:.2} % of distance within {} m; \
             max horizontal error {:.2} m (path {}, run {}, {:.0} m along it, at {:.6}, {:.6}{})",
            v.runs,
            v.paths,
            v.paths_length_km,
            v.seed,
            100.0 * v.fraction_within_requirement,
            p.requirement_m,
            v.max_horizontal_error_m,
            v.worst_path,
            v.worst_run,
            v.worst_distance_m,
            v.worst_lat,
            v.worst_lon,
            v.worst_road_id.as_ref().map(|r| format!(", road {r}")).unwrap_or_default()
        );
    }
    text!(
        out,
        "wrote {}/tags.csv, tags.geojson, tags.kml, tags.gpx, plan.json in {:.1} s",
        out_dir.display(),
        t0.elapsed().as_secs_f64()
    );
    json["out"] = serde_json::json!(out_dir.display().to_string());
    json["files"] = serde_json::json!([
        "tags.csv",
        "tags.geojson",
        "tags.kml",
        "tags.gpx",
        "plan.json"
    ]);
    json["elapsed_s"] = serde_json::json!(t0.elapsed().as_secs_f64());
    Ok(json)
}

fn simulate(
    scenario: &Path,
    tags: Option<&Path>,
    runs: u64,
    seed: Option<u64>,
    out_dir: &Path,
    out: Out,
) -> Result<serde_json::Value> {
    if runs == 0 {
        anyhow::bail!("--runs must be at least 1");
    }
    let t0 = Instant::now();
    let scn = waymark::sim::Scenario::load(scenario)?;
    let seed = seed.unwrap_or(scn.seed());
    let truth = waymark::sim::TruthSource::new(&scn)?;
    let extra = match tags {
        Some(p) => waymark::sim::tags::load_tags_csv(p)?,
        None => vec![],
    };
    let bar = if runs > 1 {
        out.bar(runs, "{bar:40} {pos}/{len} runs, {elapsed} (eta {eta})")
    } else {
        indicatif::ProgressBar::hidden()
    };
    let tick = || bar.inc(1);
    let result = waymark::sim::simulate_with(&scn, &truth, &extra, runs, seed, Some(&tick))?;
    bar.finish_and_clear();
    waymark::sim::write_output(out_dir, &result)?;
    keep_inputs(scenario, out_dir, tags)?;
    let s = &result.summary;
    text!(
        out,
        "{}: {} over {:.0} s, {:.1} km, {} run(s), seed {}: horizontal error max {:.2} m, rms {:.2} m, p95 {:.2} m; final E/N/U {:.2}/{:.2}/{:.2} m",
        s.name,
        s.mode,
        s.duration_s,
        s.distance_m / 1000.0,
        s.runs,
        s.seed,
        s.max_horizontal_error_m,
        s.rms_horizontal_error_m,
        s.p95_horizontal_error_m,
        s.final_error_enu_m[0],
        s.final_error_enu_m[1],
        s.final_error_enu_m[2],
    );
    if let Some(n) = &s.nees {
        text!(
            out,
            "filter consistency: run-averaged horizontal NEES {:.2} (95 % band {:.2}..{:.2} for {} run(s)), inside the band {:.0} % of the time, above {:.0} %",
            n.mean,
            n.band_95[0],
            n.band_95[1],
            n.runs,
            100.0 * n.fraction_within_band,
            100.0 * n.fraction_above_band
        );
    }
    let passes = result.runs.first().map_or(&[][..], |r| &r.tag_passes[..]);
    if let Some(t) = &s.tags {
        text!(
            out,
            "tag reads: {} accepted, {} rejected by the gate (all runs); run 0 passed {} tag(s), read {}",
            t.accepted,
            t.rejected,
            passes.len(),
            passes.iter().filter(|p| p.read).count()
        );
        for e in &t.rejected_run0 {
            text!(
                out,
                "  run 0: tag {} read at {:.1} s rejected (NIS {:.1})",
                e.tag_id,
                e.t_s,
                e.nis
            );
        }
    }
    for f in &s.odometer_faults {
        text!(
            out,
            "odometer failed from {:.0} s ({:.2} km) to the end",
            f.from_s,
            f.from_m / 1000.0
        );
    }
    if let Some(f) = result.runs.first().and_then(|r| r.map_feed) {
        text!(
            out,
            "map matching (run 0): {} fixes fed, {} accepted by the gate, {} at road ends, {} positions unmatched",
            f.fed, f.accepted, f.road_end, f.unmatched
        );
    }
    if let (Some(r), Some(n)) = (s.requirement_m, s.runs_exceeding_requirement) {
        text!(
            out,
            "requirement {r} m: {n} of {} run(s) exceed it; within it {:.1} % of the time",
            s.runs,
            100.0 * s.fraction_within_requirement.unwrap_or(0.0)
        );
    }
    let elapsed = t0.elapsed().as_secs_f64();
    text!(
        out,
        "wrote {} and {} in {:.2} s",
        out_dir.join("errors.csv").display(),
        out_dir.join("summary.json").display(),
        elapsed
    );
    let mut json = serde_json::to_value(s)?;
    if let Some(o) = json.as_object_mut() {
        o.remove("profile"); // long; in summary.json
    }
    let mut files = vec!["errors.csv", "summary.json", "scenario.toml", "inputs.json"];
    if s.updates_run0.is_some() {
        files.push("tag_passes.csv");
    }
    json["out"] = serde_json::json!(out_dir.display().to_string());
    json["files"] = serde_json::json!(files);
    json["elapsed_s"] = serde_json::json!(elapsed);
    Ok(json)
}

fn report(dir: &Path, out: Out) -> Result<serde_json::Value> {
    let files = waymark::report::write_report(dir)?;
    text!(
        out,
        "wrote {} and {}",
        files.report.display(),
        dir.join("plots").display()
    );
    Ok(serde_json::to_value(&files)?)
}

fn match_track(
    map: &Path,
    track: &Path,
    out_file: &Path,
    method: MatchMethod,
    truth: Option<&Path>,
    out: Out,
) -> Result<serde_json::Value> {
    use waymark::matching::{evaluate, track as tr};
    let t0 = Instant::now();
    let rows = tr::read_track(track)?;
    let net = Network::load(map, &LoadOptions::default())?;
    let truth = truth.map(|p| evaluate::read_truth(p, &net)).transpose()?;
    let load_ms = t0.elapsed().as_secs_f64() * 1e3;
    let t1 = Instant::now();
    let (method, name) = match method {
        MatchMethod::Incremental => (tr::Method::Incremental, "incremental"),
        MatchMethod::Hmm => (tr::Method::Hmm, "hmm"),
    };
    let (points, outcomes) = tr::match_rows(&net, &rows, method);
    let match_ms = t1.elapsed().as_secs_f64() * 1e3;
    let matched: usize = outcomes.iter().map(|o| o.matched).sum();
    if matched == 0 {
        anyhow::bail!(
            "{}: no point lies within 50 m of a road of {} (is the track on this map?)",
            track.display(),
            map.display()
        );
    }
    waymark::export::write_atomic(out_file, tr::matched_csv(&net, &rows, &points).as_bytes())?;
    let breaks: usize = outcomes.iter().map(|o| o.breaks.len()).sum();
    note!(
        out,
        "waymark match: {} points in {} track(s) with {name}: {matched} matched ({:.1} %), {breaks} break(s); \
        load {load_ms:.0} ms, match {match_ms:.1} ms; wrote {}",
        rows.len(),
        outcomes.len(),
        100.0 * matched as f64 / rows.len() as f64,
        out_file.display()
    );
    let mut break_list = Vec::new();
    let mut span_list = Vec::new();
    for o in &outcomes {
        let label = if o.track_id.is_empty() {
            String::new()
        } else {
            format!("track {}: ", o.track_id)
        };
        if o.matched == 0 {
            note!(
                out,
                "  {label}no point matched: the whole track is off the map's roads"
            );
            continue;
        }
        for b in &o.breaks {
            let before = b
                .before
                .map(|(_, t)| format!("{t} s"))
                .unwrap_or_else(|| "the start".into());
            let line = rows[o.rows[b.after.0 as usize]].line;
            note!(
                out,
                "  {label}break ({}) between {before} and {} s (line {line})",
                b.reason.as_str(),
                b.after.1,
            );
            break_list.push(serde_json::json!({
                "track_id": o.track_id,
                "reason": b.reason.as_str(),
                "before_t_s": b.before.map(|(_, t)| t),
                "after_t_s": b.after.1,
                "line": line,
            }));
        }
        for sp in &o.unmatched {
            let (l0, l1) = (
                rows[o.rows[sp.first as usize]].line,
                rows[o.rows[sp.last as usize]].line,
            );
            note!(
                out,
                "  {label}unmatched span: lines {l0}-{l1} (t {} s to {} s, {} points)",
                sp.t_s[0],
                sp.t_s[1],
                sp.last - sp.first + 1
            );
            span_list.push(serde_json::json!({
                "track_id": o.track_id,
                "first_line": l0,
                "last_line": l1,
                "t_s": sp.t_s,
                "points": sp.last - sp.first + 1,
            }));
        }
    }
    let mut score_json = serde_json::Value::Null;
    if let Some(truth) = truth {
        let mut lengths = evaluate::RoadLengths::new();
        for o in &outcomes {
            let pts: Vec<_> = o.rows.iter().map(|&i| points[i]).collect();
            for (k, v) in evaluate::matched_lengths(&net, &pts) {
                *lengths.entry(k).or_default() += v;
            }
        }
        let s = evaluate::score(&lengths, &truth);
        text!(
            out,
            "precision_length {:.4} recall_length {:.4} precision_count {:.4} recall_count {:.4} \
            matched_length_m {:.1} truth_length_m {:.1} roads matched {} true {} correct {}",
            s.precision_length,
            s.recall_length,
            s.precision_count,
            s.recall_count,
            s.matched_length_m,
            s.truth_length_m,
            s.matched_roads,
            s.truth_roads,
            s.correct_roads
        );
        score_json = serde_json::json!({
            "precision_length": s.precision_length,
            "recall_length": s.recall_length,
            "precision_count": s.precision_count,
            "recall_count": s.recall_count,
            "matched_length_m": s.matched_length_m,
            "truth_length_m": s.truth_length_m,
            "matched_roads": s.matched_roads,
            "truth_roads": s.truth_roads,
            "correct_roads": s.correct_roads,
        });
    }
    Ok(serde_json::json!({
        "map": map.display().to_string(),
        "track": track.display().to_string(),
        "out": out_file.display().to_string(),
        "method": name,
        "points": rows.len(),
        "tracks": outcomes.len(),
        "matched": matched,
        "matched_share": matched as f64 / rows.len() as f64,
        "breaks": break_list,
        "unmatched_spans": span_list,
        "score": score_json,
        "timings_ms": { "load": load_ms, "match": match_ms },
    }))
}

/// The main job on the bundled map: plan, validate, simulate with the
/// planned tags, report.
fn demo(out_dir: &Path, out: Out) -> Result<serde_json::Value> {
    let t0 = Instant::now();
    let scenario = bundled("scenarios/demo.toml");
    text!(
        out,
        "waymark demo: planning RFID tags for {} (bundled Helsinki map, 20 m requirement)",
        scenario.display()
    );
    let plan_json = plan(&scenario, out_dir, None, None, false, out)?;
    text!(
        out,
        "waymark demo: simulating the route with the planned tags (20 runs) for the report"
    );
    let tags = out_dir.join("tags.csv");
    let sim_json = simulate(&scenario, Some(&tags), 20, None, out_dir, out)?;
    let files = report(out_dir, out)?;
    let elapsed = t0.elapsed().as_secs_f64();
    text!(
        out,
        "waymark demo: done in {:.1} s. Open {} in a browser; installer files: {}/tags.csv, tags.geojson, tags.kml, tags.gpx; plan and validation: {}/plan.json",
        elapsed,
        out_dir.join("report.html").display(),
        out_dir.display(),
        out_dir.display()
    );
    let pick = |v: &serde_json::Value, keys: &[&str]| -> serde_json::Value {
        keys.iter()
            .map(|k| (k.to_string(), v[*k].clone()))
            .collect::<serde_json::Map<_, _>>()
            .into()
    };
    Ok(serde_json::json!({
        "out": out_dir.display().to_string(),
        "report": files["report"],
        "files": [
            "tags.csv", "tags.geojson", "tags.kml", "tags.gpx", "plan.json", "profile.csv",
            "errors.csv", "summary.json", "tag_passes.csv", "scenario.toml", "inputs.json",
            "report.html"
        ],
        "plan": pick(&plan_json, &[
            "tag_count", "tags_by_mounting", "requirement_m", "total_cost", "max_gap_m",
            "predicted_max_bound95_m", "method", "validation"
        ]),
        "simulation": pick(&sim_json, &[
            "runs", "duration_s", "distance_m", "max_horizontal_error_m",
            "p95_horizontal_error_m", "fraction_within_requirement",
            "time_to_exceed_requirement_s"
        ]),
        "elapsed_s": elapsed,
    }))
}

/// A file shipped with Waymark: relative to the working folder when run from
/// the project, else from the source tree it was built from.
fn bundled(rel: &str) -> PathBuf {
    let local = PathBuf::from(rel);
    if local.exists() {
        local
    } else {
        Path::new(env!("CARGO_MANIFEST_DIR")).join(rel)
    }
}

fn inspect(
    map: &Path,
    options: LoadOptions,
    tolerance: f64,
    defects_out: Option<&Path>,
    out: Out,
) -> Result<serde_json::Value> {
    if !(tolerance.is_finite() && tolerance >= 0.0) {
        anyhow::bail!("--tolerance must be a non-negative number of metres, got {tolerance}");
    }
    let net = Network::load(map, &options)?;
    let t = Instant::now();
    let defects = net.defects(tolerance);
    let defects_ms = t.elapsed().as_secs_f64() * 1e3;
    let report = waymark::network::inspect(&map.display().to_string(), &net, &defects, defects_ms);
    if let Some(path) = defects_out {
        waymark::export::write_atomic(path, waymark::export::defects_geojson(&defects).as_bytes())
            .with_context(|| "writing the defect file")?;
    }
    if out.json {
        // Printed here, in the report's own field order, as before `--json`
        // became common to every command.
        use std::io::Write as _;
        let _ = writeln!(
            std::io::stdout(),
            "{}",
            serde_json::to_string_pretty(&report)?
        );
        return Ok(serde_json::Value::Null);
    }
    out.text_raw(format_args!("{}", report.to_text()));
    Ok(serde_json::Value::Null)
}
