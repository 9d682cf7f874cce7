//! The integration tests, one module per former `tests/NAME.rs`, in one
//! test binary: the library is linked once, and every test shares one
//! harness's threads (`cargo test --release --test it MODULE::`).
//! `tests/route_memory.rs` stays a binary of its own: it installs a
//! counting `#[global_allocator]` and must be alone in its process.

#[path = "../common/mod.rs"]
mod common;

mod architecture;
mod area_planner;
mod cli_bad_inputs;
mod cli_extremes;
mod cli_init;
mod cli_manners;
mod cli_match;
mod cli_match_formats;
mod cli_match_model;
mod cli_match_real;
mod cli_match_stream;
mod cli_network;
mod cli_outputs;
mod cli_reliability;
mod elevation;
mod error_budgets;
mod export_tags;
mod filter;
mod filter_cli;
mod index;
mod lanes;
mod map_matching_nav;
mod map_realism;
mod matching_accuracy;
mod matching_behaviour;
mod matching_incremental;
mod matching_independent;
mod matching_paths_cache;
mod matching_restart;
mod matching_sparse;
mod network_model;
mod plan_reasons;
mod plan_regression;
mod plan_speed;
mod planner;
mod planner_network;
mod random_streams;
mod report;
mod report_content;
mod report_damaged;
mod report_network;
mod route;
mod route_trajectory;
mod shapefile;
mod simulate_cli;
mod simulate_lib;
