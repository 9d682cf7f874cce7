//! What an output folder keeps of its inputs, for `waymark report`.

use crate::error::{Error, Result};
use crate::fsio::write_atomic;
use std::path::Path;

/// Makes sure `dir` can hold a command's output files before any work
/// starts: creates it (and its parents) when missing; an existing path that
/// is not a folder is an error naming it.
pub fn prepare_out_dir(dir: &Path) -> Result<()> {
    if dir.exists() && !dir.is_dir() {
        return Err(Error::format(
            dir,
            "the output folder is an existing file, not a folder",
        ));
    }
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))
}

/// Keeps a copy of the scenario (`scenario.toml`) and where it and the tag
/// file were (`inputs.json`) in an output folder, so that `waymark report`
/// can draw the map later.
pub fn keep_inputs(scenario: &Path, out_dir: &Path, tags: Option<&Path>) -> Result<()> {
    let text = std::fs::read(scenario).map_err(|e| Error::io(scenario, e))?;
    write_atomic(&out_dir.join("scenario.toml"), &text)?;
    crate::report::write_inputs(out_dir, scenario, tags)
}
