//! How a job reports progress without printing.

/// Receives a job's progress: notes between its steps, and counts within a
/// long step (planning candidate sites, Monte Carlo runs). Every method has
/// an empty default, so an implementation picks what it shows.
pub trait Progress: Sync {
    /// A step starts (e.g. "validating 2 tag(s) by 100 Monte Carlo run(s)").
    fn note(&self, _message: &str) {}
    /// A counted step starts: `total` units of `unit` (e.g. "runs").
    fn start(&self, _unit: &str, _total: u64) {}
    /// `done` of `total` units are done.
    fn set(&self, _done: u64, _total: u64) {}
    /// The counted step is over.
    fn finish(&self) {}
}

/// Progress that goes nowhere.
#[derive(Debug, Clone, Copy, Default)]
pub struct Silent;

impl Progress for Silent {}
