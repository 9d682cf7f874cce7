//! What an output folder keeps of its inputs, for `waymark report`.

use crate::error::{Error, Result};
use crate::fsio::write_atomic;
use std::path::Path;

/// Keeps a copy of the scenario (`scenario.toml`) and where it and the tag
/// file were (`inputs.json`) in an output folder, so that `waymark report`
/// can draw the map later.
pub fn keep_inputs(scenario: &Path, out_dir: &Path, tags: Option<&Path>) -> Result<()> {
    let text = std::fs::read(scenario).map_err(|e| Error::io(scenario, e))?;
    write_atomic(&out_dir.join("scenario.toml"), &text)?;
    crate::report::write_inputs(out_dir, scenario, tags)
}
