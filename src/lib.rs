//! Waymark plans RFID tag infrastructure for vehicles navigating without
//! satellite positioning and evaluates how accurately they know their position
//! along their routes.
//!
//! This crate is the whole engine; the `waymark` binary is a thin layer over it.
#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod attitude;
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

pub use error::{Error, Result};
pub use network::{LoadOptions, Network};
