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
#[command(after_help = "Exit codes: 0 success, 1 bad input or failure, 2 bad command line.")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Runs the main job on the bundled map and scenario: plans tags for a 20 m requirement, validates them, writes the installer files and an HTML report.
    #[command(after_help = "Example:\n  waymark demo\n  waymark demo --out /tmp/waymark-demo")]
    Demo {
        /// Output folder.
        #[arg(long, default_value = "waymark-demo")]
        out: PathBuf,
    },
    /// Road network commands.
    #[command(subcommand)]
    Network(NetworkCommand),
    /// Writes DIR/report.html (self-contained: inline SVG plots, no network) and PNG plots for a simulate output folder.
    #[command(
        after_help = "Example:\n  waymark simulate scenarios/helsinki-route-dr.toml --out /tmp/hel\n  \
        waymark report /tmp/hel"
    )]
    Report {
        /// The output folder of `waymark simulate`.
        dir: PathBuf,
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
    },
    /// Simulates a scenario: truth, sensors and navigator; writes errors.csv and summary.json.
    #[command(
        after_help = "Examples:\n  waymark simulate scenarios/schuler-accel-bias.toml --out /tmp/schuler\n  \
        waymark simulate scenarios/dr3d-paper.toml --runs 10 --seed 7 --out /tmp/dr3d\n  \
        waymark simulate scenarios/nees-consistency.toml --runs 100 --out /tmp/nees\n  \
        waymark simulate drive.toml --tags tags.csv --runs 20 --out /tmp/drive"
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
    },
    /// Plans RFID tags for a scenario's route: the fewest tags keeping the predicted 95 % horizontal error within requirement_m; validates by Monte Carlo; writes tags.csv/.geojson/.kml/.gpx and plan.json.
    #[command(
        after_help = "Examples:\n  waymark plan scenarios/helsinki-plan-tactical.toml --out /tmp/plan\n  \
        waymark plan drive.toml --runs 20 --seed 3 --out /tmp/drive-plan"
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
        /// Also find the uniform-spacing baseline: the largest spacing whose validation keeps ≥ 99 % of distance within the requirement.
        #[arg(long)]
        baseline: bool,
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

/// Prints a line to stdout; a closed pipe (e.g. `| head`) is not an error.
macro_rules! say {
    ($($t:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stdout(), $($t)*);
    }};
}

/// Prints to stdout without a newline; a closed pipe is not an error.
macro_rules! say_raw {
    ($($t:tt)*) => {{
        use std::io::Write as _;
        let _ = write!(std::io::stdout(), $($t)*);
    }};
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("waymark: error: {e:#}");
            ExitCode::from(1)
        }
    }
}

fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Demo { out } => demo(&out),
        Command::Simulate {
            scenario,
            tags,
            runs,
            seed,
            out,
        } => simulate(&scenario, tags.as_deref(), runs, seed, &out),
        Command::Report { dir } => report(&dir),
        Command::Plan {
            scenario,
            out,
            runs,
            seed,
            baseline,
        } => plan(&scenario, &out, runs, seed, baseline),
        Command::Match {
            map,
            track,
            out,
            method,
            truth,
        } => match_track(&map, &track, &out, method, truth.as_deref()),
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
            inspect(&map, json, options, tolerance, defects.as_deref())
        }
    }
}

fn plan(
    scenario: &Path,
    out: &Path,
    runs: Option<u64>,
    seed: Option<u64>,
    baseline: bool,
) -> Result<()> {
    use waymark::planner;
    let t0 = Instant::now();
    let scn = waymark::sim::Scenario::load(scenario)?;
    let seed = seed.or(scn.file.seed).unwrap_or(1);
    let mut settings = planner::PlannerSettings::from_scenario(&scn)?;
    if let Some(r) = runs {
        settings.validation_runs = r;
    }
    if settings.coverage == planner::Coverage::Network {
        return write_network_plan(&scn, &settings, out, seed, baseline);
    }
    let truth = waymark::sim::TruthSource::new(&scn)?;
    eprintln!(
        "waymark plan: {}: covariance analysis along the route, then placement",
        scn.file.name
    );
    let bar = if std::io::IsTerminal::is_terminal(&std::io::stderr()) {
        let b = indicatif::ProgressBar::new(0);
        b.set_style(
            indicatif::ProgressStyle::with_template(
                "{bar:40} {pos}/{len} candidate sites, {elapsed} (eta {eta})",
            )
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        b
    } else {
        indicatif::ProgressBar::hidden()
    };
    let tick = |done: usize, total: usize| {
        bar.set_length(total as u64);
        bar.set_position(done as u64);
    };
    let mut p = planner::plan_with_progress(&scn, &truth, &settings, seed, false, Some(&tick))?;
    bar.finish_and_clear();
    let t_plan = t0.elapsed().as_secs_f64();
    if settings.validation_runs > 0 {
        eprintln!(
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
        eprintln!("waymark plan: searching the uniform-spacing baseline");
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
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    use waymark::export::{tags_csv, tags_geojson, tags_gpx, tags_kml, write_atomic};
    write_atomic(&out.join("tags.csv"), tags_csv(&recs, &meta).as_bytes())?;
    write_atomic(
        &out.join("tags.geojson"),
        tags_geojson(&recs, &meta).as_bytes(),
    )?;
    write_atomic(&out.join("tags.kml"), tags_kml(&recs, &meta).as_bytes())?;
    write_atomic(&out.join("tags.gpx"), tags_gpx(&recs, &meta).as_bytes())?;
    let mut json = serde_json::to_value(&p)?;
    json["tag_count"] = serde_json::json!(p.tag_count());
    json["existing_tags_kept"] = serde_json::json!(p.existing_count());
    json["tags_by_mounting"] = serde_json::json!(p.by_mounting());
    json["waymark_version"] = serde_json::json!(env!("CARGO_PKG_VERSION"));
    json["plan_time_s"] = serde_json::json!(t_plan);
    write_atomic(
        &out.join("plan.json"),
        serde_json::to_string_pretty(&json)?.as_bytes(),
    )?;
    let by: Vec<String> = p
        .by_mounting()
        .iter()
        .map(|(k, v)| format!("{v} {k}"))
        .collect();
    println!(
        "{}: {} new tag(s) ({}){} over {:.1} km, total cost {:.1}, max gap {:.0} m; requirement {} m with {} missed read(s) tolerated; predicted max 95 % bound {:.2} m (all read); method: {}",
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
        p.method
    );
    if let Some(v) = &p.validation {
        println!(
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
            Some(b) => println!(
                "uniform baseline: {} tag(s) every {:.0} m keep {:.2} % of distance within {} m ({} run(s)); plan uses {}{}",
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
            None => println!(
                "uniform baseline: none validates, even at the candidate spacing"
            ),
        }
    }
    println!(
        "wrote {}/tags.csv, tags.geojson, tags.kml, tags.gpx, plan.json in {:.1} s",
        out.display(),
        t0.elapsed().as_secs_f64()
    );
    Ok(())
}

/// `waymark plan` for `coverage = "network"`: plan, validate, write the files.
fn write_network_plan(
    scn: &waymark::sim::Scenario,
    settings: &waymark::planner::PlannerSettings,
    out: &Path,
    seed: u64,
    baseline: bool,
) -> Result<()> {
    use waymark::export::{tags_csv, tags_geojson, tags_gpx, tags_kml, write_atomic};
    use waymark::planner::network;
    if baseline {
        anyhow::bail!("--baseline compares with uniform spacing along a route; it does not apply to coverage = \"network\"");
    }
    let t0 = Instant::now();
    eprintln!(
        "waymark plan: {}: network coverage (reach from the filter, then placement on every directed road)",
        scn.file.name
    );
    let mut p = network::plan_network(scn, settings, seed, false)?;
    let t_plan = t0.elapsed().as_secs_f64();
    if settings.validation_runs > 0 {
        eprintln!(
            "waymark plan: validating {} tag(s) by {} Monte Carlo run(s) on sampled paths",
            p.tag_count(),
            settings.validation_runs
        );
        let net = network::scenario_network(scn)?;
        p.validation = Some(network::validate_network_plan(
            scn,
            &net,
            &p,
            settings.validation_runs,
            seed,
        )?);
    }
    let (recs, meta) = p.export(scn)?;
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    write_atomic(&out.join("tags.csv"), tags_csv(&recs, &meta).as_bytes())?;
    write_atomic(
        &out.join("tags.geojson"),
        tags_geojson(&recs, &meta).as_bytes(),
    )?;
    write_atomic(&out.join("tags.kml"), tags_kml(&recs, &meta).as_bytes())?;
    write_atomic(&out.join("tags.gpx"), tags_gpx(&recs, &meta).as_bytes())?;
    let mut json = serde_json::to_value(&p)?;
    json["tag_count"] = serde_json::json!(p.tag_count());
    json["tags_by_mounting"] = serde_json::json!(p.by_mounting());
    json["waymark_version"] = serde_json::json!(env!("CARGO_PKG_VERSION"));
    json["plan_time_s"] = serde_json::json!(t_plan);
    write_atomic(
        &out.join("plan.json"),
        serde_json::to_string_pretty(&json)?.as_bytes(),
    )?;
    let by: Vec<String> = p
        .by_mounting()
        .iter()
        .map(|(k, v)| format!("{v} {k}"))
        .collect();
    println!(
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
        println!(
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
    println!(
        "wrote {}/tags.csv, tags.geojson, tags.kml, tags.gpx, plan.json in {:.1} s",
        out.display(),
        t0.elapsed().as_secs_f64()
    );
    Ok(())
}

fn simulate(
    scenario: &Path,
    tags: Option<&Path>,
    runs: u64,
    seed: Option<u64>,
    out: &Path,
) -> Result<()> {
    if runs == 0 {
        anyhow::bail!("--runs must be at least 1");
    }
    let t0 = Instant::now();
    let scn = waymark::sim::Scenario::load(scenario)?;
    let seed = seed.or(scn.file.seed).unwrap_or(1);
    let truth = waymark::sim::TruthSource::new(&scn)?;
    let extra = match tags {
        Some(p) => waymark::sim::tags::load_tags_csv(p)?,
        None => vec![],
    };
    let bar = if runs > 1 && std::io::IsTerminal::is_terminal(&std::io::stderr()) {
        let b = indicatif::ProgressBar::new(runs);
        b.set_style(
            indicatif::ProgressStyle::with_template(
                "{bar:40} {pos}/{len} runs, {elapsed} (eta {eta})",
            )
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        b
    } else {
        indicatif::ProgressBar::hidden()
    };
    let tick = || bar.inc(1);
    let result = waymark::sim::simulate_with(&scn, &truth, &extra, runs, seed, Some(&tick))?;
    bar.finish_and_clear();
    waymark::sim::output::write(out, &result)?;
    // What `waymark report` needs to redraw the map later.
    let text =
        std::fs::read(scenario).with_context(|| format!("{}: cannot read", scenario.display()))?;
    waymark::export::write_atomic(&out.join("scenario.toml"), &text)?;
    waymark::report::write_inputs(out, scenario, tags)?;
    let s = &result.summary;
    say!(
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
        say!(
            "filter consistency: run-averaged horizontal NEES {:.2} (95 % band {:.2}..{:.2} for {} run(s)), inside the band {:.0} % of the time, above {:.0} %",
            n.mean,
            n.band_95[0],
            n.band_95[1],
            n.runs,
            100.0 * n.fraction_within_band,
            100.0 * n.fraction_above_band
        );
    }
    if let Some(t) = &s.tags {
        say!(
            "tag reads: {} accepted, {} rejected by the gate (all runs)",
            t.accepted,
            t.rejected
        );
        for e in &t.rejected_run0 {
            say!(
                "  run 0: tag {} read at {:.1} s rejected (NIS {:.1})",
                e.tag_id,
                e.t_s,
                e.nis
            );
        }
    }
    if let Some(f) = result.runs.first().and_then(|r| r.map_feed) {
        println!(
            "map matching (run 0): {} fixes fed, {} accepted by the gate, {} at road ends, {} positions unmatched",
            f.fed, f.accepted, f.road_end, f.unmatched
        );
    }
    if let (Some(r), Some(n)) = (s.requirement_m, s.runs_exceeding_requirement) {
        say!(
            "requirement {r} m: {n} of {} run(s) exceed it; within it {:.1} % of the time",
            s.runs,
            100.0 * s.fraction_within_requirement.unwrap_or(0.0)
        );
    }
    say!(
        "wrote {} and {} in {:.2} s",
        out.join("errors.csv").display(),
        out.join("summary.json").display(),
        t0.elapsed().as_secs_f64()
    );
    Ok(())
}

fn report(dir: &Path) -> Result<()> {
    use waymark::export::write_atomic;
    use waymark::report::{
        bound95, error_plot_png, read_output_folder, render_html, ErrorSeries, PlotDecor,
    };
    let input = read_output_folder(dir)?;
    let html = render_html(&input)?;
    let out = dir.join("report.html");
    write_atomic(&out, html.as_bytes())?;
    let plots = dir.join("plots");
    std::fs::create_dir_all(&plots)
        .with_context(|| format!("{}: cannot create folder", plots.display()))?;
    let requirement = input.summary["requirement_m"].as_f64();
    let error: Vec<f64> = input.rows.iter().map(|r| r.horizontal_m).collect();
    let bound: Vec<Option<f64>> = input
        .rows
        .iter()
        .map(|r| r.sigma_en_m.map(bound95))
        .collect();
    for (file, label, x) in [
        (
            "error_time.png",
            "time (s)",
            input.rows.iter().map(|r| r.t_s).collect::<Vec<_>>(),
        ),
        (
            "error_distance.png",
            "distance driven (m)",
            input.rows.iter().map(|r| r.distance_m).collect(),
        ),
    ] {
        let series = ErrorSeries {
            envelope: waymark::report::envelope(&input.summary, label.starts_with("time")),
            x,
            error: error.clone(),
            bound95: bound.clone(),
        };
        let decor = PlotDecor {
            title: format!(
                "Horizontal error against {}",
                label.split(' ').next().unwrap_or("")
            ),
            x_label: label.into(),
            requirement_m: requirement,
            ..Default::default()
        };
        write_atomic(
            &plots.join(file),
            &error_plot_png(&series, &decor, (1200, 520))?,
        )?;
    }
    println!("wrote {} and {}", out.display(), plots.display());
    Ok(())
}

fn match_track(
    map: &Path,
    track: &Path,
    out: &Path,
    method: MatchMethod,
    truth: Option<&Path>,
) -> Result<()> {
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
    waymark::export::write_atomic(out, tr::matched_csv(&net, &rows, &points).as_bytes())?;
    let breaks: usize = outcomes.iter().map(|o| o.breaks.len()).sum();
    eprintln!(
        "waymark match: {} points in {} track(s) with {name}: {matched} matched ({:.1} %), {breaks} break(s); \
        load {load_ms:.0} ms, match {match_ms:.1} ms; wrote {}",
        rows.len(),
        outcomes.len(),
        100.0 * matched as f64 / rows.len() as f64,
        out.display()
    );
    for o in &outcomes {
        let label = if o.track_id.is_empty() {
            String::new()
        } else {
            format!("track {}: ", o.track_id)
        };
        if o.matched == 0 {
            eprintln!("  {label}no point matched: the whole track is off the map's roads");
            continue;
        }
        for b in &o.breaks {
            let before = b
                .before
                .map(|(_, t)| format!("{t} s"))
                .unwrap_or_else(|| "the start".into());
            eprintln!(
                "  {label}break ({}) between {before} and {} s (line {})",
                b.reason.as_str(),
                b.after.1,
                rows[o.rows[b.after.0 as usize]].line
            );
        }
        for s in &o.unmatched {
            eprintln!(
                "  {label}unmatched span: lines {}-{} (t {} s to {} s, {} points)",
                rows[o.rows[s.first as usize]].line,
                rows[o.rows[s.last as usize]].line,
                s.t_s[0],
                s.t_s[1],
                s.last - s.first + 1
            );
        }
    }
    if let Some(truth) = truth {
        let mut lengths = evaluate::RoadLengths::new();
        for o in &outcomes {
            let pts: Vec<_> = o.rows.iter().map(|&i| points[i]).collect();
            for (k, v) in evaluate::matched_lengths(&net, &pts) {
                *lengths.entry(k).or_default() += v;
            }
        }
        let s = evaluate::score(&lengths, &truth);
        println!(
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
    }
    Ok(())
}

/// The main job on the bundled map: plan, validate, simulate with the
/// planned tags, report.
fn demo(out: &Path) -> Result<()> {
    let t0 = Instant::now();
    let scenario = bundled("scenarios/demo.toml");
    say!(
        "waymark demo: planning RFID tags for {} (bundled Helsinki map, 20 m requirement)",
        scenario.display()
    );
    plan(&scenario, out, None, None, false)?;
    say!("waymark demo: simulating the route with the planned tags (20 runs) for the report");
    let tags = out.join("tags.csv");
    simulate(&scenario, Some(&tags), 20, None, out)?;
    report(out)?;
    say!(
        "waymark demo: done in {:.1} s. Open {} in a browser; installer files: {}/tags.csv, tags.geojson, tags.kml, tags.gpx; plan and validation: {}/plan.json",
        t0.elapsed().as_secs_f64(),
        out.join("report.html").display(),
        out.display(),
        out.display()
    );
    Ok(())
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
    json: bool,
    options: LoadOptions,
    tolerance: f64,
    defects_out: Option<&Path>,
) -> Result<()> {
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
    if json {
        say!("{}", serde_json::to_string_pretty(&report)?);
    } else {
        say_raw!("{}", report.to_text());
    }
    Ok(())
}
