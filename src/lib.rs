//! Waymark plans RFID tag infrastructure for vehicles navigating without
//! satellite positioning (tunnels, mines, ports) and evaluates how accurately
//! they know their position along their routes.
//!
//! This crate is the whole engine; the `waymark` binary is a thin layer over
//! it. The names below, re-exported at the crate root, are the supported
//! API; the topic modules ([`network`], [`matching`], [`sim`], [`planner`],
//! …) hold the rest of each topic's public types.
//!
//! # A short tour
//!
//! | Task | Entry points |
//! |---|---|
//! | Load a road network (OSM PBF/XML, GeoJSON, shapefile) | [`Network::load`], [`LoadOptions`] |
//! | Plan a route through waypoints | [`plan_route`] → [`Route`] |
//! | Match a track to the roads | [`HmmMatcher`] / [`IncrementalMatcher`] (both [`Matcher`]), [`match_track`], [`Fix`] → [`MatchedPoint`] |
//! | Read and validate a scenario (TOML) | [`Scenario::load`], [`Scenario::parse`] |
//! | Simulate navigation (Monte Carlo) | [`TruthSource::new`], [`simulate`], [`simulate_with`] → [`SimResult`] ([`Summary`]); [`write_output`] |
//! | Plan tags along a route or over a network | [`PlannerSettings::from_scenario`], [`plan`], [`plan_with`] → [`Plan`] ([`PlannedTag`]); [`plan_network`] → [`NetworkPlan`] |
//! | Terrain heights from a GeoTIFF elevation model (`[map] elevation`) | [`Dem::open`], [`Dem::height`]; along a route [`trajectory::route_heights`] → [`HeightProfile`], driven by [`trajectory::RoutePlan::with_heights`]; over a network [`trajectory::NetworkHeights`] |
//! | Export tag lists | [`tags_csv`], [`tags_geojson`], [`tags_kml`], [`tags_gpx`] of [`TagRecord`]s with [`ExportMetadata`]; [`write_atomic`] |
//! | Write the HTML report of an output folder | [`write_report`] → [`ReportFiles`] |
//! | Run a whole command's job into an output folder (what the binary calls) | [`workflow::plan_folder`], [`workflow::simulate_folder`], [`workflow::match_file`], [`workflow::inspect_map`], [`workflow::demo_folder`], reporting through a [`workflow::Progress`] |
//! | Errors | [`Error`] (bad input names the file and field; [`Error::Infeasible`] when no plan can meet the requirement), [`Result`] |
//!
//! Every random process is seeded: the same inputs and seed give the same
//! results.
//!
//! ## Loading a network
//!
//! ```
//! use waymark::{LoadOptions, Network};
//!
//! let map = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("maps/helsinki.osm.pbf");
//! let net = Network::load(&map, &LoadOptions::default())?;
//! assert!(net.roads.len() > 100 && net.sections.len() > 100);
//! // Every segment is indexed for nearest-road queries.
//! assert_eq!(net.rtree.len(), net.segments.len());
//! # Ok::<(), waymark::Error>(())
//! ```
//!
//! ## Matching a track
//!
//! Fixes every 20 m along a route on the bundled map, offset 4 m east and
//! carrying the direction of travel (which tells a dual carriageway's two
//! roads apart), are matched back onto the route's roads:
//!
//! ```
//! use waymark::{match_track, plan_route, Fix, HmmMatcher, HmmParams, MatchState, Network};
//!
//! let map = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("maps/helsinki.osm.pbf");
//! let net = Network::load(&map, &Default::default())?;
//! let route = plan_route(&net, &[[60.1660, 24.9380], [60.1770, 24.9510]])?;
//! let along: Vec<f64> = (0..(route.length_m / 20.0) as usize).map(|i| i as f64 * 20.0).collect();
//! let fixes: Vec<Fix> = along
//!     .iter()
//!     .map(|&s| {
//!         let p = route.position_at(s);
//!         let (a, b) = (route.position_at(s - 5.0), route.position_at(s + 5.0));
//!         // Heading: radians clockwise from north.
//!         let heading = (b[0] - a[0]).atan2(b[1] - a[1]);
//!         Fix { t_s: s / 10.0, enu: [p[0] + 4.0, p[1]], heading_rad: Some(heading) }
//!     })
//!     .collect();
//! let mut matcher = HmmMatcher::new(&net, HmmParams::default());
//! let points = match_track(&mut matcher, &fixes);
//! assert_eq!(points.len(), fixes.len());
//! for (p, &s) in points.iter().zip(&along) {
//!     assert_eq!(p.state, MatchState::Matched);
//!     assert!(route.spans.iter().any(|span| Some(span.road) == p.road));
//!     let truth = route.position_at(s);
//!     let miss = (p.point[0] - truth[0]).hypot(p.point[1] - truth[1]);
//!     assert!(miss < 6.0, "{miss} m at {s} m");
//! }
//! # Ok::<(), waymark::Error>(())
//! ```
//!
//! ## Simulating a scenario
//!
//! A scenario given as motion commands (no map), one Monte Carlo run:
//!
//! ```
//! use waymark::{simulate, Scenario, TruthSource};
//!
//! let text = r#"
//! name = "doc"
//! [[route]]
//! start = { lat = 52.0, lon = 5.0, height_m = 10.0, heading_deg = 90.0 }
//! motion = [ { kind = "accelerate", to_kmh = 50, accel_mps2 = 1.5 },
//!            { kind = "cruise", duration_s = 60 } ]
//! [navigator]
//! mode = "dead_reckoning"
//! "#;
//! let scn = Scenario::parse(std::path::Path::new("doc.toml"), text)?;
//! let truth = TruthSource::new(&scn)?;
//! let result = simulate(&scn, &truth, 1, 7)?;
//! assert_eq!(result.runs.len(), 1);
//! // v²/2a to reach 50 km/h, then 60 s at 50 km/h: 64.3 m + 833.3 m.
//! let v = 50.0 / 3.6;
//! assert!((result.summary.distance_m - (v * v / 3.0 + 60.0 * v)).abs() < 1.0);
//! let e = result.summary.max_horizontal_error_m;
//! assert!(e.is_finite() && e < 0.05 * result.summary.distance_m, "{e}");
//! # Ok::<(), waymark::Error>(())
//! ```
//!
//! ## Planning tags
//!
//! A 3 m requirement on a 2.2 km route of the bundled map for a tactical IMU
//! with an odometer; the route planner places the fewest tags that hold the
//! requirement with one missed read tolerated:
//!
//! ```
//! use waymark::{plan_with, PlannerSettings, Scenario, TruthSource};
//!
//! let text = r#"
//! name = "doc-plan"
//! requirement_m = 3.0
//! [map]
//! path = "maps/helsinki.osm.pbf"
//! [[route]]
//! waypoints = [[60.1660, 24.9380], [60.1770, 24.9510]]
//! speed_kmh = 50
//! [navigator]
//! mode = "integrated"
//! [imu]
//! rate_hz = 100
//! gyro_bias_dph = [0.5, 0.5, 0.5]
//! accel_bias_ug = [100, 100, 100]
//! gyro_arw_dprh = 0.05
//! accel_vrw_ugprhz = 50
//! [aiding]
//! odometer = true
//! rfid = true
//! [planner]
//! tolerate_missed_reads = 1
//! "#;
//! // Relative paths in a scenario are relative to its file.
//! let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("doc-plan.toml");
//! let scn = Scenario::parse(&path, text)?;
//! let settings = PlannerSettings::from_scenario(&scn)?;
//! let truth = TruthSource::new(&scn)?;
//! let plan = plan_with(&scn, &truth, &settings, 1, false)?;
//! assert!(plan.tags.len() >= 1);
//! assert!(plan.predicted_max_bound95_m <= plan.requirement_m);
//! # Ok::<(), waymark::Error>(())
//! ```
#![forbid(unsafe_code)]
#![warn(missing_docs)]
#![warn(unnameable_types)]

pub mod attitude;
pub mod decimal;
pub mod elevation;
pub mod error;
pub mod export;
pub mod fsio;
pub mod geodesy;
pub mod matching;
pub mod nav;
pub mod network;
pub mod planner;
pub mod report;
pub mod route;
pub mod scenario;
pub mod sensors;
pub mod sim;
pub mod tags;
pub mod trajectory;
pub mod units;
pub mod workflow;

pub use elevation::{Dem, HeightProfile};
pub use error::{Error, Result};
pub use export::{tags_csv, tags_geojson, tags_gpx, tags_kml, write_atomic};
pub use matching::{
    match_track, Fix, HmmMatcher, HmmParams, IncrementalMatcher, IncrementalParams, MatchState,
    MatchedPoint, Matcher,
};
pub use network::{LoadOptions, Network};
pub use planner::network::{plan_network, NetworkPlan};
pub use planner::{plan, plan_with, Plan, PlannedTag, PlannerSettings};
pub use report::{write_report, ReportFiles};
pub use route::{plan_route, Route};
pub use scenario::Scenario;
pub use sim::{simulate, simulate_with, write_output, SimResult, Summary, TruthSource};
pub use tags::{ExportMetadata, Mounting, TagRecord};
