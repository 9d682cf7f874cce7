//! `waymark simulate` in integrated mode as a real binary: tags from a CSV
//! with `--tags`, the filter's sigma columns in errors.csv, the summary's
//! Monte Carlo and consistency fields, and bad tag files.

use crate::common;

use common::{repo, run};

use std::path::{Path, PathBuf};
use waymark::sim::{Scenario, TruthSource};

/// The nees-consistency drive without its own tags.
fn scenario_without_tags(dir: &Path) -> PathBuf {
    let text = std::fs::read_to_string(repo("scenarios/nees-consistency.toml")).unwrap();
    let cut = text.find("[[tag]]").unwrap();
    let p = dir.join("drive.toml");
    std::fs::write(&p, &text[..cut]).unwrap();
    p
}

#[test]
fn tags_csv_feeds_the_filter_and_sigma_columns_are_filled() {
    let dir = tempfile::tempdir().unwrap();
    let scn_path = scenario_without_tags(dir.path());
    // Tag positions on the drive at 100, 250 and 400 s, from the truth.
    let scn = Scenario::load(&scn_path).unwrap();
    let truth = TruthSource::new(&scn).unwrap();
    let mut csv = String::from("tag_id,lat,lon,height_m,road_id,chainage_m,side,mounting,expected_fix_sigma_m,payload_hex\n");
    let mut want = vec![100.0, 250.0, 400.0].into_iter().peekable();
    let mut i = 0;
    for a in truth.samples() {
        if let Some(&t) = want.peek() {
            if a.t >= t {
                let m = ["road_surface", "roadside", "ceiling"][i];
                csv.push_str(&format!(
                    "T{i},{:.9},{:.9},,,,,{m},,\n",
                    a.state.lat.to_degrees(),
                    a.state.lon.to_degrees()
                ));
                i += 1;
                want.next();
            }
        }
    }
    std::fs::write(dir.path().join("tags.csv"), csv).unwrap();
    let o = run(
        &[
            "simulate",
            "drive.toml",
            "--tags",
            "tags.csv",
            "--runs",
            "4",
            "--seed",
            "5",
            "--out",
            "out",
        ],
        dir.path(),
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let s: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(dir.path().join("out/summary.json")).unwrap(),
    )
    .unwrap();
    assert_eq!(s["runs"], 4);
    // Read probability 0.977 over 3 tags × 4 runs: at least 9 reads accepted,
    // none rejected (all are where they say).
    let acc = s["tags"]["accepted"].as_u64().unwrap();
    assert!((9..=12).contains(&acc), "{acc}");
    assert_eq!(s["tags"]["rejected"], 0);
    for k in [
        "rms_horizontal_error_m",
        "p95_horizontal_error_m",
        "max_horizontal_error_m",
        "fraction_within_requirement",
    ] {
        assert!(s[k].as_f64().is_some(), "{k}");
    }
    assert!(s["nees"]["band_95"][0].as_f64().unwrap() > 0.0);
    assert!(s["profile"].as_array().unwrap().len() > 100);
    assert!(s["profile"][10]["p95_m"].as_f64().is_some());
    let text = std::fs::read_to_string(dir.path().join("out/errors.csv")).unwrap();
    let mut lines = text.lines();
    assert_eq!(
        lines.next().unwrap(),
        "t_s,distance_m,east_m,north_m,up_m,horizontal_m,sigma_east_m,sigma_north_m,sigma_up_m,bound95_m"
    );
    let (mut n, mut correlated) = (0, 0);
    for l in lines {
        let f: Vec<f64> = l.split(',').map(|x| x.parse().unwrap()).collect();
        assert_eq!(f.len(), 10);
        assert!(f[6] > 0.0 && f[7] > 0.0 && f[8] > 0.0, "{l}");
        // The bound from the full covariance lies between the diagonal's
        // (2.4477·max σ, where east and north are uncorrelated) and
        // 2.4477·√(σ_E² + σ_N²) (λ_max ≤ the trace). Tolerance 1e-3 m:
        // each column is rounded to 1e-4 m, times 2.45 at most.
        let k = waymark::sim::CHI2_2_95.sqrt();
        let (diag, trace) = (k * f[6].max(f[7]), k * f[6].hypot(f[7]));
        assert!(f[9] >= diag - 1e-3 && f[9] <= trace + 1e-3, "{l}");
        if f[9] > 1.01 * diag {
            correlated += 1;
        }
        n += 1;
    }
    assert!(n > 500);
    // The drive turns: the error ellipse is tilted on some rows, where the
    // diagonal bound would understate the filter's own bound by over 1 %.
    assert!(correlated > 10, "{correlated} of {n} rows");
}

fn bad_tags(csv: &str, needle: &str) {
    let dir = tempfile::tempdir().unwrap();
    scenario_without_tags(dir.path());
    std::fs::write(dir.path().join("t.csv"), csv).unwrap();
    let o = run(
        &["simulate", "drive.toml", "--tags", "t.csv", "--out", "out"],
        dir.path(),
    );
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    assert_eq!(err.trim_end().lines().count(), 1, "{err}");
    assert!(
        err.contains("t.csv") && err.contains(needle),
        "wanted {needle:?} in {err}"
    );
    assert!(!dir.path().join("out").exists());
}

#[test]
fn bad_tag_files_give_clear_errors() {
    bad_tags(
        "tag_id,lat,lon\nA,45,10\n",
        "line 1: header must have tag_id, lat, lon and mounting",
    );
    bad_tags(
        "tag_id,lat,lon,mounting\nA,45,10,road_surface\nB,north,10,roadside\n",
        "line 3: lat \"north\" is not a number",
    );
    bad_tags(
        "tag_id,lat,lon,mounting\nA,45,10,wall\n",
        "line 2: mounting \"wall\"",
    );
    bad_tags(
        "tag_id,lat,lon,mounting\nA,95,10,ceiling\n",
        "line 2: lat 95 is outside",
    );
    bad_tags(
        "tag_id,lat,lon,mounting\nA,45,10,ceiling\nA,45,10,ceiling\n",
        "line 3: duplicate tag_id \"A\"",
    );
    bad_tags(
        "tag_id,lat,lon,mounting\nA,45,10\n",
        "line 2: 3 fields, the header has 4",
    );
    bad_tags("", "empty file");
    let dir = tempfile::tempdir().unwrap();
    scenario_without_tags(dir.path());
    let o = run(
        &["simulate", "drive.toml", "--tags", "missing.csv"],
        dir.path(),
    );
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        err.contains("missing.csv") && !err.contains("panicked"),
        "{err}"
    );
}

#[test]
fn tags_need_the_integrated_navigator() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("t.csv"),
        "tag_id,lat,lon,mounting\nA,45,10,ceiling\n",
    )
    .unwrap();
    let o = run(
        &[
            "simulate",
            repo("scenarios/dr-straight-10km.toml").to_str().unwrap(),
            "--tags",
            "t.csv",
            "--out",
            "out",
        ],
        dir.path(),
    );
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("integrated"), "{err}");
}
