//! The `waymark` command line: a thin layer over the library.

use anyhow::Result;
use clap::{Parser, Subcommand};
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use waymark::matching::options::MatchOptions;
use waymark::network::{LoadOptions, DEFAULT_NODE_TOLERANCE_M};
use waymark::workflow::{
    self, MatchJob, PlanJob, PlanOutcome, Progress, SimulateJob, SimulateOutcome,
};

/// Plans RFID tag infrastructure for vehicles navigating without satellite
/// positioning, and evaluates their position accuracy along routes.
#[derive(Parser)]
#[command(name = "waymark", version, about, long_about = None)]
#[command(after_help = "Examples:\n  waymark demo\n  \
    waymark plan scenarios/demo.toml --out /tmp/plan && waymark report /tmp/plan\n  \
    waymark simulate scenarios/helsinki-route-dr.toml --json -q --out /tmp/hel\n\n\
    Output: results on stdout (one JSON object with --json); progress, notes and \
    logs (-v) on stderr; progress bars only when stderr is a terminal.\n\
    Exit codes: 0 success, 1 bad input or failure, 2 bad command line, \
    130 stopped by a signal (SIGINT, SIGTERM; the file being written is removed).")]
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
    /// Matches positions (TRACK.csv, GPX or GeoJSON) to the road network; writes MATCHED.csv
    /// and, with --path, the complete path driven.
    #[command(
        after_help = "TRACK: CSV with header t_s,lat,lon and optionally heading_deg,speed_mps,track_id; \
        or GPX (each track segment a track); or GeoJSON (LineString / MultiPoint features) \
        - recognised by content.\n\
        TRUTH.csv (for --truth): header road_id and optionally length_m.\n\
        PATH.csv (--path): track_id,seq,road_id,from_offset_m,to_offset_m,length_m in driving order.\n\
        Examples:\n  waymark match --map maps/helsinki.osm.pbf --track track.csv --out matched.csv\n  \
        waymark match --map maps/helsinki.osm.pbf --track drive.gpx --path path.csv --path-geojson path.geojson\n  \
        waymark match --map maps/helsinki.osm.pbf --track track.csv --method incremental --truth truth.csv"
    )]
    Match {
        /// The map: .osm.pbf, .osm (XML), .geojson or .shp.
        #[arg(long)]
        map: PathBuf,
        /// The positions to match: CSV, GPX or GeoJSON.
        #[arg(long, value_name = "TRACK")]
        track: PathBuf,
        /// Output file.
        #[arg(long, value_name = "MATCHED.csv", default_value = "matched.csv")]
        out: PathBuf,
        /// Matcher.
        #[arg(long, value_enum, default_value = "hmm")]
        method: MatchMethod,
        /// The HMM's model: drift (per-survivor drift, smoothed confidence) or independent (Newson and Krumm: one emission per candidate, filtered confidence, less work per point).
        #[arg(long, default_value = "drift")]
        model: waymark::matching::HmmModel,
        /// Scores the complete path against the roads actually driven (CSV with road_id[,length_m]).
        #[arg(long, value_name = "TRUTH.csv")]
        truth: Option<PathBuf>,
        /// Writes the complete path (roads driven, in order, between and through the points).
        #[arg(long, value_name = "PATH.csv")]
        path: Option<PathBuf>,
        /// Writes the complete path as GeoJSON (a LineString per continuous piece).
        #[arg(long, value_name = "PATH.geojson")]
        path_geojson: Option<PathBuf>,
        /// Candidate search radius (m) [default: from the track, 4 σ̂ within 100-300 m]; candidates less than 1e-6 as likely as a point's best are dropped.
        #[arg(long, value_name = "M", value_parser = waymark::workflow::number_in(1.0, 1000.0))]
        radius_m: Option<f64>,
        /// σ of the position noise (m) [default: from the track, at least 5 m].
        #[arg(long, value_name = "M", value_parser = waymark::workflow::number_in(0.1, 500.0))]
        sigma_m: Option<f64>,
        /// Highest plausible speed: a transition may route at most this speed × the time between points.
        #[arg(long, value_name = "KMH", default_value_t = MatchOptions::default().max_speed_kmh, value_parser = waymark::workflow::number_in(1.0, 1000.0))]
        max_speed_kmh: f64,
        /// Time between points that breaks the track (s).
        #[arg(long, value_name = "S", default_value_t = MatchOptions::default().max_gap_s, value_parser = waymark::workflow::number_in(0.1, 86_400.0))]
        max_gap_s: f64,
        /// Distance between points that breaks the track (m).
        #[arg(long, value_name = "M", default_value_t = MatchOptions::default().max_gap_m, value_parser = waymark::workflow::number_in(1.0, 100_000.0))]
        max_gap_m: f64,
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
        /// Monte Carlo runs (1 to 100000).
        #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u64).range(1..=waymark::sim::MAX_RUNS))]
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
    /// Writes a commented starting scenario (IMU class preset, odometer, RFID, planner): on a map's roads with --map, for every road with --network, else a drive by motion commands. Edit it, then plan, simulate and report.
    #[command(
        after_help = "Examples:\n  waymark init                                  # scenario.toml: a drive by motion commands\n  \
        waymark init --map maps/helsinki.osm.pbf --out route.toml\n  \
        waymark init --map maps/helsinki.osm.pbf --network --out area.toml"
    )]
    Init {
        /// The map the scenario drives on (.osm.pbf, .osm, .geojson, .shp); two waypoints are chosen on it.
        #[arg(long)]
        map: Option<PathBuf>,
        /// Plan tags for every road of the map in each permitted direction (planner.coverage = "network"); needs --map.
        #[arg(long, requires = "map")]
        network: bool,
        /// The scenario file to write (must not exist).
        #[arg(long, default_value = "scenario.toml")]
        out: PathBuf,
        /// Print one JSON object (the file, the map, the waypoints) on stdout.
        #[arg(long)]
        json: bool,
    },
    /// Plans RFID tags: along the scenario's route (planner.coverage = "routes", the default: the fewest tags keeping the predicted 95 % horizontal error within requirement_m with tolerate_missed_reads consecutive tags missed), or for the whole map (coverage = "network": every drivable road in each permitted direction, for the traffic planner.traffic names: "trips", the default, chains of trips between destinations, stated as "with confidence 1 − β a new chain breaks the requirement with probability at most ε" from fresh sampled chains; or "any_walk", every path the network allows; reports the reach between fixes and a lower bound on the tag count; validated by simulating sampled chains). Validates by Monte Carlo; writes tags.csv (header first), tags.meta.json, tags.geojson/.kml/.gpx, plan.json, profile.csv (routes) and, for `waymark report`, scenario.toml and inputs.json.
    #[command(
        after_help = "Examples:\n  waymark plan scenarios/helsinki-plan-tactical.toml --out /tmp/plan\n  \
        waymark plan drive.toml --runs 20 --seed 3 --out /tmp/drive-plan\n  \
        waymark plan scenarios/demo.toml --baseline --json --out /tmp/demo-plan\n  \
        waymark plan scenarios/helsinki-network-plan.toml --out /tmp/area   # network coverage"
    )]
    Plan {
        /// The scenario file (TOML) with requirement_m and an integrated navigator.
        scenario: PathBuf,
        /// Output folder.
        #[arg(long, default_value = "waymark-plan")]
        out: PathBuf,
        /// Validation runs, up to 100000 (default: planner.validation_runs, else 100; 0 skips validation).
        #[arg(long, value_parser = clap::value_parser!(u64).range(0..=waymark::sim::MAX_RUNS))]
        runs: Option<u64>,
        /// Base seed of the validation (default: the scenario's `seed`, else 1).
        #[arg(long)]
        seed: Option<u64>,
        /// Also compute a baseline. Route coverage: the uniform-spacing baseline, the largest spacing that passes the plan's covariance check (any k consecutive tags missed) and whose validation keeps ≥ 99 % of distance within the requirement. Network coverage: the validation's chains, runs and seeds driven again without the planned tags (installed ones kept), to show what the tags buy.
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
        /// The map: .osm.pbf, .osm (XML), .geojson (format follows the content) or .shp (with its .dbf).
        map: PathBuf,
        /// Print one JSON object instead of text.
        #[arg(long)]
        json: bool,
        /// Also load highway=track.
        #[arg(long)]
        tracks: bool,
        /// Grid size N (a power of two up to 2048); chosen from the map's size by default.
        #[arg(long, value_parser = grid_size)]
        grid_n: Option<u32>,
        /// Distance below which two unjoined nodes are reported (m, 0 to 1000).
        #[arg(long, default_value_t = DEFAULT_NODE_TOLERANCE_M, value_parser = tolerance_m)]
        tolerance: f64,
        /// Write every defect as a GeoJSON point to this file.
        #[arg(long, value_name = "FILE")]
        defects: Option<PathBuf>,
    },
}

/// `--grid-n`: a power of two up to the grid's limit (else exit 2).
fn grid_size(s: &str) -> std::result::Result<u32, String> {
    let max = waymark::network::MAX_GRID_N;
    match s.parse::<u32>() {
        Ok(n) if n.is_power_of_two() && n <= max => Ok(n),
        _ => Err(format!("must be a power of two from 1 to {max}")),
    }
}

/// `--tolerance`: metres, finite, 0 to 1000 (else exit 2).
fn tolerance_m(s: &str) -> std::result::Result<f64, String> {
    match s.parse::<f64>() {
        Ok(x) if (0.0..=1000.0).contains(&x) => Ok(x),
        _ => Err("must be a number of metres from 0 to 1000".into()),
    }
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
            stdout_written(writeln!(std::io::stdout(), "{args}"));
        }
    }

    /// The human-readable result without a trailing newline.
    fn text_raw(&self, args: std::fmt::Arguments) {
        use std::io::Write as _;
        if self.quiet {
        } else if self.json {
            let _ = write!(std::io::stderr(), "{args}");
        } else {
            stdout_written(write!(std::io::stdout(), "{args}"));
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
    // clap checks `conflicts_with` between global flags only when both sit
    // on the same side of the subcommand (`waymark -q simulate ... -v`
    // passed): checked again here, with clap's own message and exit 2.
    if cli.quiet && cli.verbose > 0 {
        use clap::CommandFactory as _;
        Cli::command()
            .error(
                clap::error::ErrorKind::ArgumentConflict,
                "the argument '--quiet' cannot be used with '--verbose'",
            )
            .exit();
    }
    init_logging(cli.verbose);
    // SIGINT, SIGTERM: remove the output file being written (its hidden
    // temporary), then stop with 130.
    let _ = ctrlc::set_handler(|| {
        waymark::fsio::remove_temporaries();
        std::process::exit(130);
    });
    match run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        // The signal handler removed the file being written: its exit code.
        Err(_) if waymark::fsio::stopping() => ExitCode::from(130),
        Err(e) => {
            // Not `eprintln!`: it panics (exit 101) when stderr cannot be
            // written (`2>/dev/full`); the exit code still says it failed.
            use std::io::Write as _;
            let _ = writeln!(std::io::stderr(), "waymark: error: {e:#}");
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
        } => {
            let job = SimulateJob {
                scenario: &scenario,
                tags: tags.as_deref(),
                runs,
                seed,
                out_dir: &dir,
            };
            (json, simulate(&job, out(json))?)
        }
        Command::Report { dir, json } => (json, report(&dir, out(json))?),
        Command::Init {
            map,
            network,
            out: file,
            json,
        } => {
            let o = workflow::init_scenario(&file, map.as_deref(), network)?;
            out(json).text(format_args!(
                "wrote {} ({}); next: waymark plan {} --out plan",
                o.scenario.display(),
                match (&o.map, o.network) {
                    (Some(m), true) => format!("network coverage of {}", m.display()),
                    (Some(m), false) => format!("a route on {}", m.display()),
                    (None, _) => "a drive by motion commands".into(),
                },
                o.scenario.display()
            ));
            (json, serde_json::to_value(&o)?)
        }
        Command::Plan {
            scenario,
            out: dir,
            runs,
            seed,
            baseline,
            json,
        } => {
            let job = PlanJob {
                scenario: &scenario,
                out_dir: &dir,
                runs,
                seed,
                baseline,
            };
            (json, plan(&job, out(json))?)
        }
        Command::Match {
            map,
            track,
            out: file,
            method,
            model,
            truth,
            path,
            path_geojson,
            radius_m,
            sigma_m,
            max_speed_kmh,
            max_gap_s,
            max_gap_m,
            json,
        } => {
            let job = MatchJob {
                map: &map,
                track: &track,
                out_file: &file,
                options: MatchOptions {
                    method: match method {
                        MatchMethod::Incremental => workflow::MatchMethod::Incremental,
                        MatchMethod::Hmm => workflow::MatchMethod::Hmm,
                    },
                    model,
                    radius_m,
                    sigma_m,
                    max_speed_kmh,
                    max_gap_s,
                    max_gap_m,
                },
                truth: truth.as_deref(),
                path: path.as_deref(),
                path_geojson: path_geojson.as_deref(),
            };
            (json, match_track(&job, out(json))?)
        }
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
        stdout_written(writeln!(
            std::io::stdout(),
            "{}",
            serde_json::to_string_pretty(&value)?
        ));
    }
    stdout_finished()
}

/// The first failure to write a result on stdout, other than a closed pipe.
static STDOUT_ERROR: std::sync::Mutex<Option<std::io::Error>> = std::sync::Mutex::new(None);

/// Records the outcome of writing a result on stdout. A closed pipe (e.g.
/// `| head`) is not an error; any other failure (a full disk behind
/// `> out.json`) fails the command once it is done, rather than exit 0 with
/// its result lost.
fn stdout_written(r: std::io::Result<()>) {
    if let Err(e) = r {
        if e.kind() != std::io::ErrorKind::BrokenPipe {
            STDOUT_ERROR
                .lock()
                .unwrap_or_else(|p| p.into_inner())
                .get_or_insert(e);
        }
    }
}

/// Flushes stdout; an error if a result could not be written on it.
fn stdout_finished() -> Result<()> {
    use std::io::Write as _;
    stdout_written(std::io::stdout().flush());
    match STDOUT_ERROR
        .lock()
        .unwrap_or_else(|p| p.into_inner())
        .take()
    {
        Some(e) => Err(anyhow::anyhow!("standard output: {e}")),
        None => Ok(()),
    }
}

/// The bar and notes of a job, on stderr (see [`Out`]).
struct Shown {
    out: Out,
    bar: std::sync::Mutex<Option<indicatif::ProgressBar>>,
}

impl Shown {
    fn new(out: Out) -> Self {
        Shown {
            out,
            bar: std::sync::Mutex::new(None),
        }
    }
}

impl Progress for Shown {
    fn note(&self, message: &str) {
        self.out.note(format_args!("{message}"));
    }
    fn start(&self, unit: &str, total: u64) {
        let b = self.out.bar(
            total,
            &format!("{{bar:40}} {{pos}}/{{len}} {unit}, {{elapsed}} (eta {{eta}})"),
        );
        *self.bar.lock().unwrap_or_else(|e| e.into_inner()) = Some(b);
    }
    fn set(&self, done: u64, total: u64) {
        if let Some(b) = &*self.bar.lock().unwrap_or_else(|e| e.into_inner()) {
            b.set_length(total);
            b.set_position(done);
        }
    }
    fn finish(&self) {
        if let Some(b) = self.bar.lock().unwrap_or_else(|e| e.into_inner()).take() {
            b.finish_and_clear();
        }
    }
}

fn plan(job: &PlanJob, out: Out) -> Result<serde_json::Value> {
    let o = workflow::plan_folder(job, &Shown::new(out))?;
    print_plan(&o, job.baseline, out);
    Ok(serde_json::to_value(&o)?)
}

fn print_plan(o: &PlanOutcome, baseline: bool, out: Out) {
    for line in o.summary(baseline) {
        text!(out, "{line}");
    }
}

fn simulate(job: &SimulateJob, out: Out) -> Result<serde_json::Value> {
    let o = workflow::simulate_folder(job, &Shown::new(out))?;
    print_simulation(&o, out);
    let mut json = serde_json::to_value(&o.result.summary)?;
    if let Some(obj) = json.as_object_mut() {
        obj.remove("profile"); // long; in summary.json
        obj.insert("out".into(), serde_json::json!(o.out.display().to_string()));
        obj.insert("files".into(), serde_json::json!(o.files));
        obj.insert("elapsed_s".into(), serde_json::json!(o.elapsed_s));
        if let Some(r) = &o.requirement_rule {
            obj.insert("requirement_rule".into(), r.clone());
        }
    }
    Ok(json)
}

fn print_simulation(o: &SimulateOutcome, out: Out) {
    for n in &o.notes {
        note!(out, "waymark simulate: note: {n}");
    }
    for line in o.summary() {
        text!(out, "{line}");
    }
}

fn report(dir: &Path, out: Out) -> Result<serde_json::Value> {
    let files = waymark::report::write_report(dir)?;
    print_report(&files, dir, out);
    Ok(serde_json::to_value(&files)?)
}

fn print_report(files: &waymark::report::ReportFiles, dir: &Path, out: Out) {
    for m in &files.missing {
        note!(out, "waymark report: warning: {}: {m}", dir.display());
    }
    text!(
        out,
        "wrote {} and {}",
        files.report.display(),
        dir.join("plots").display()
    );
}

fn match_track(job: &MatchJob, out: Out) -> Result<serde_json::Value> {
    let o = workflow::match_file(job)?;
    note!(
        out,
        "waymark match: {} points in {} track(s) ({}) with {}: {} matched ({:.1} %), {} break(s), \
        path {:.0} m in {} piece(s); load {:.0} ms, match {:.1} ms; wrote {}",
        o.points,
        o.tracks,
        o.format,
        o.method,
        o.matched,
        100.0 * o.matched_share,
        o.breaks.len(),
        o.path_length_m,
        o.path_pieces,
        o.timings_ms.load,
        o.timings_ms.r#match,
        std::iter::once(o.out.as_str())
            .chain(o.path_files.iter().map(String::as_str))
            .collect::<Vec<_>>()
            .join(", ")
    );
    let label = |id: &str| {
        if id.is_empty() {
            String::new()
        } else {
            format!("track {id}: ")
        }
    };
    for id in &o.unmatched_tracks {
        note!(
            out,
            "  {}no point matched: the whole track is off the map's roads",
            label(id)
        );
    }
    for b in &o.breaks {
        let before = b
            .before_t_s
            .map(|t| format!("{t} s"))
            .unwrap_or_else(|| "the start".into());
        note!(
            out,
            "  {}break ({}) between {before} and {} s (line {})",
            label(&b.track_id),
            b.reason,
            b.after_t_s,
            b.line
        );
    }
    for sp in &o.unmatched_spans {
        note!(
            out,
            "  {}unmatched span: lines {}-{} (t {} s to {} s, {} points)",
            label(&sp.track_id),
            sp.first_line,
            sp.last_line,
            sp.t_s[0],
            sp.t_s[1],
            sp.points
        );
    }
    if let Some(s) = &o.score {
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
    }
    Ok(serde_json::to_value(&o)?)
}

/// The main job on the bundled map: plan, validate, simulate with the
/// planned tags, report.
fn demo(out_dir: &Path, out: Out) -> Result<serde_json::Value> {
    let scenario = bundled("scenarios/demo.toml");
    text!(
        out,
        "waymark demo: planning RFID tags for {} (bundled Helsinki map, 20 m requirement)",
        scenario.display()
    );
    let o = workflow::demo_folder(&scenario, out_dir, &Shown::new(out))?;
    print_plan(&o.plan, false, out);
    print_simulation(&o.simulation, out);
    print_report(&o.report, out_dir, out);
    text!(
        out,
        "waymark demo: done in {:.1} s. Open {} in a browser; installer files: {}/tags.csv, tags.geojson, tags.kml, tags.gpx; plan and validation: {}/plan.json",
        o.elapsed_s,
        out_dir.join("report.html").display(),
        out_dir.display(),
        out_dir.display()
    );
    let plan_json = serde_json::to_value(&o.plan)?;
    let sim_json = serde_json::to_value(&o.simulation.result.summary)?;
    let pick = |v: &serde_json::Value, keys: &[&str]| -> serde_json::Value {
        keys.iter()
            .map(|k| (k.to_string(), v[*k].clone()))
            .collect::<serde_json::Map<_, _>>()
            .into()
    };
    Ok(serde_json::json!({
        "out": out_dir.display().to_string(),
        "report": o.report.report,
        "files": o.files,
        "plan": pick(&plan_json, &[
            "tag_count", "tags_by_mounting", "requirement_m", "total_cost", "max_gap_m",
            "predicted_max_bound95_m", "method", "validation"
        ]),
        "simulation": pick(&sim_json, &[
            "runs", "duration_s", "distance_m", "max_horizontal_error_m",
            "p95_horizontal_error_m", "fraction_within_requirement",
            "time_to_exceed_requirement_s"
        ]),
        "elapsed_s": o.elapsed_s,
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
    let report = workflow::inspect_map(map, &options, tolerance, defects_out)?;
    if out.json {
        // Printed here, in the report's own field order, as before `--json`
        // became common to every command.
        use std::io::Write as _;
        stdout_written(writeln!(
            std::io::stdout(),
            "{}",
            serde_json::to_string_pretty(&report)?
        ));
        return Ok(serde_json::Value::Null);
    }
    out.text_raw(format_args!("{}", report.to_text()));
    Ok(serde_json::Value::Null)
}
