//! The scenario moved to [`crate::scenario`]; this re-export keeps the old
//! path importable.

pub use crate::scenario::*;
