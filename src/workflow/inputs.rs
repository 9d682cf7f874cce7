//! What an output folder keeps of its inputs, for `waymark report`.

use crate::error::{Error, Result};
use crate::fsio::write_atomic;
use std::path::Path;

/// Checks, before any work starts, that `dir` can become a command's output
/// folder: it is a folder or does not exist yet, and its nearest existing
/// ancestor is a folder. Nothing is created here: a command that fails on
/// its input leaves no folder behind; the folder is made when the files are
/// written.
pub fn check_out_dir(dir: &Path) -> Result<()> {
    let not_folder =
        |p: &Path| Error::format(p, "the output folder is an existing file, not a folder");
    let mut p = Some(dir);
    while let Some(q) = p.filter(|q| !q.as_os_str().is_empty()) {
        if q.exists() {
            return if q.is_dir() {
                Ok(())
            } else {
                Err(not_folder(q))
            };
        }
        p = q.parent();
    }
    Ok(())
}

/// Keeps a copy of the scenario (`scenario.toml`) and where it and the tag
/// file were (`inputs.json`) in an output folder, so that `waymark report`
/// can draw the map later.
pub fn keep_inputs(scenario: &Path, out_dir: &Path, tags: Option<&Path>) -> Result<()> {
    let text = std::fs::read(scenario).map_err(|e| Error::io(scenario, e))?;
    write_atomic(&out_dir.join("scenario.toml"), &text)?;
    crate::report::write_inputs(out_dir, scenario, tags)
}
