//! What an output folder keeps of its inputs, for `waymark report`, and the
//! clearing of an earlier run's outputs before a command writes its own.

use crate::error::{Error, Result};
use crate::fsio::write_atomic;
use crate::scenario::{RouteKind, Scenario};
use std::path::{Path, PathBuf};

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

/// Where `path` leads on disk, to tell whether two paths name the same
/// file: the canonical path of an existing file, else its canonical folder
/// joined with its name (`None` when neither can be resolved).
fn file_identity(path: &Path) -> Option<std::path::PathBuf> {
    if let Ok(p) = path.canonicalize() {
        return Some(p);
    }
    let name = path.file_name()?;
    let parent = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    parent.canonicalize().ok().map(|p| p.join(name))
}

/// Checks, before any work, that no output file is one of the inputs or
/// another output (each given with the option that names it): writing it
/// would destroy an input, or one output would silently replace another.
pub(super) fn check_distinct_files(
    outputs: &[(&Path, &str)],
    inputs: &[(&Path, &str)],
) -> Result<()> {
    for (i, (out, out_opt)) in outputs.iter().enumerate() {
        let Some(id) = file_identity(out) else {
            continue;
        };
        let earlier = outputs[..i].iter().map(|(p, o)| (p, o, "output"));
        for (other, opt, kind) in inputs.iter().map(|(p, o)| (p, o, "input")).chain(earlier) {
            if file_identity(other).as_ref() == Some(&id) {
                return Err(Error::format(
                    out,
                    format!(
                        "{out_opt} is the same file as the {kind} {opt}: writing it would \
                         {}; choose another {out_opt}",
                        if kind == "input" {
                            "destroy the input"
                        } else {
                            "replace the other output"
                        }
                    ),
                ));
            }
        }
    }
    Ok(())
}

/// The files of a scenario that a command reads besides the scenario
/// itself, each with the field that names it: the map, the elevation
/// model's tiles, the installed tags and the destinations.
pub(super) fn scenario_inputs(scn: &Scenario) -> Vec<(PathBuf, &'static str)> {
    let mut inputs = Vec::new();
    if let RouteKind::Map { map, .. } = &scn.route {
        inputs.push((map.clone(), "map.path"));
    }
    for tile in &scn.elevation {
        inputs.push((tile.clone(), "map.elevation"));
    }
    let p = scn.planner();
    if let Some(f) = &p.existing_tags {
        inputs.push((f.clone(), "planner.existing_tags"));
    }
    if let Some(f) = &p.destinations {
        inputs.push((f.clone(), "planner.destinations"));
    }
    inputs
}

/// Checks, before any work, that no input is a file the command replaces in
/// its output folder `dir` (`own`, as given to [`clear_outputs`], and the
/// report made from the folder): `planner.existing_tags = "plan/tags.csv"`
/// with `--out plan` replaced the installed tags with the new plan's, and a
/// plan that adds no tag left an empty file. The copy of the scenario
/// (`scenario.toml`) is not one of them: it may be run again into its own
/// folder.
pub(super) fn check_inputs_outside_outputs(
    dir: &Path,
    own: &[&str],
    inputs: &[(PathBuf, &str)],
) -> Result<()> {
    for (input, field) in inputs {
        let Some(id) = file_identity(input) else {
            continue;
        };
        for name in own.iter().chain(&["report.html"]) {
            if file_identity(&dir.join(name)).as_ref() == Some(&id) {
                return Err(Error::format(
                    input,
                    format!(
                        "{field} is the output folder's {name}, which this command replaces: \
                         writing it would destroy the input; choose another --out, or move \
                         the file out of {}",
                        dir.display()
                    ),
                ));
            }
        }
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

/// What `waymark simulate` writes (beside the inputs).
pub(super) const SIMULATION_OUTPUTS: &[&str] = &[
    "errors.csv",
    "summary.json",
    "tag_passes.csv",
    "calibration.csv",
];
/// What `waymark plan` writes (beside the inputs).
pub(super) const PLAN_OUTPUTS: &[&str] = &[
    "tags.csv",
    "tags.geojson",
    "tags.kml",
    "tags.gpx",
    "plan.json",
    "profile.csv",
    // An area plan's; a route plan written over one must not leave it for
    // the report to draw as its own.
    "coverage.geojson",
];

/// Before a command writes its files into `dir` (made if missing): removes
/// the files an earlier run of the same kind wrote there (`own`: all of
/// them, so none that this run does not write is left beside its own, e.g.
/// an integrated run's `tag_passes.csv` under a dead-reckoning run), and the
/// report made from the earlier content (`report.html`, `plots/*.png`).
/// The copies of the inputs (`scenario.toml`, `inputs.json`) are left: every
/// command that clears its outputs writes them again after its results, and
/// the scenario being run may itself be `dir/scenario.toml` (the copy an
/// earlier run kept, edited and run again into the same folder). Files
/// Waymark does not write are never touched.
pub(super) fn clear_outputs(dir: &Path, own: &[&str]) -> Result<()> {
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    let remove = |p: &Path| match std::fs::remove_file(p) {
        Err(e) if e.kind() != std::io::ErrorKind::NotFound => Err(Error::io(p, e)),
        _ => Ok(()),
    };
    for f in own {
        remove(&dir.join(f))?;
    }
    remove(&dir.join("report.html"))?;
    let plots = dir.join("plots");
    if let Ok(entries) = std::fs::read_dir(&plots) {
        for e in entries.flatten() {
            let p = e.path();
            if p.extension().is_some_and(|x| x == "png") && p.is_file() {
                remove(&p)?;
            }
        }
        // Removed only when that leaves it empty.
        let _ = std::fs::remove_dir(&plots);
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clearing_removes_own_kind_and_report_only() {
        let d = tempfile::tempdir().unwrap();
        let dir = d.path();
        for f in [
            "errors.csv",
            "tag_passes.csv",
            "calibration.csv",
            "plan.json",
            "notes.txt",
            "report.html",
        ] {
            std::fs::write(dir.join(f), "x").unwrap();
        }
        std::fs::create_dir(dir.join("plots")).unwrap();
        std::fs::write(dir.join("plots/error_time.png"), "x").unwrap();
        clear_outputs(dir, SIMULATION_OUTPUTS).unwrap();
        let mut left: Vec<String> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        left.sort();
        assert_eq!(left, ["notes.txt", "plan.json"]);
    }
}
