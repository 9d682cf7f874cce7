//! Network coverage (`planner.coverage = "network"`): `waymark plan` as a
//! real binary on the bundled Helsinki map, the library's plan checked by the
//! walk DP, re-planning with the plan installed, and bad input.

use crate::common;

use common::{repo, run};

use std::path::{Path, PathBuf};
use waymark::planner::network::cover::check;
use waymark::planner::network::{plan_network, plan_network_on, scenario_network};
use waymark::planner::PlannerSettings;
use waymark::sim::Scenario;

/// The Helsinki network scenario, edited, written next to a copy-free map
/// path (absolute) in `dir`.
fn scenario_file(dir: &Path, edit: impl Fn(String) -> String) -> PathBuf {
    let text = std::fs::read_to_string(repo("scenarios/helsinki-network-plan.toml"))
        .unwrap()
        .replace(
            "../maps/helsinki.osm.pbf",
            repo("maps/helsinki.osm.pbf").to_str().unwrap(),
        );
    let p = dir.join("s.toml");
    std::fs::write(&p, edit(text)).unwrap();
    p
}

#[test]
fn network_plan_cli_on_helsinki_writes_verified_validated_plan() {
    let dir = tempfile::tempdir().unwrap();
    let scn = repo("scenarios/helsinki-network-plan.toml");
    let out = run(
        &[
            "plan",
            scn.to_str().unwrap(),
            "--out",
            "out",
            "--runs",
            "20",
        ],
        dir.path(),
    );
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}{stdout}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(stdout.contains("network coverage"), "{stdout}");
    let o = dir.path().join("out");
    let plan: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(o.join("plan.json")).unwrap()).unwrap();
    assert_eq!(plan["coverage"], "network");
    assert_eq!(plan["verified"], true);
    let n = plan["tag_count"].as_u64().unwrap() as usize;
    let lb = plan["lower_bound"].as_u64().unwrap() as usize;
    let r = plan["reach_m"].as_f64().unwrap();
    // A 20 m requirement with a MEMS IMU and odometer: the reach is a few
    // hundred metres to a few km, never more than the steady or start reach.
    assert!((200.0..5000.0).contains(&r), "{r}");
    assert!(r <= plan["steady_reach_m"].as_f64().unwrap() + 1e-9);
    assert!(r <= plan["start_reach_m"].as_f64().unwrap() + 1e-9);
    // The longest walk with ≤ k tags stays within the error budget, and the
    // budget's reference (fastest class) is at least the tightest reach.
    assert!(plan["longest_walk_budget"].as_f64().unwrap() <= 1.0 + 1e-9);
    assert!(plan["budget_reference_m"].as_f64().unwrap() >= r);
    assert!(lb > 0 && lb <= n, "lower bound {lb}, tags {n}");
    assert!(plan["directed_edges"].as_u64().unwrap() > 1000);
    assert!(plan["candidates"].as_u64().unwrap() >= plan["directed_edges"].as_u64().unwrap());
    assert!(plan["method"]
        .as_str()
        .unwrap()
        .contains("verified by the walk DP"));
    assert_eq!(
        plan["tags_by_mounting"]["road_surface"].as_u64().unwrap() as usize,
        n
    );
    // Validation: 20 runs on sampled paths, ≥ 99 % of distance within 20 m
    // (the plan holds the predicted 95 % bound within 20 m on every walk, so
    // far fewer than 1 % of distance may exceed it).
    let v = &plan["validation"];
    assert_eq!(v["runs"].as_u64().unwrap(), 20);
    assert!(v["paths"].as_u64().unwrap() >= 5);
    assert!(
        v["fraction_within_requirement"].as_f64().unwrap() >= 0.99,
        "{v}"
    );
    assert!(v["max_horizontal_error_m"].as_f64().unwrap() > 0.0);
    assert!(v["worst_lat"].as_f64().unwrap() > 60.0);
    // No baseline without `--baseline`.
    assert!(v["without_new_tags"].is_null(), "{v}");
    // Files: one CSV row and one feature per new tag, with payloads.
    let csv = std::fs::read_to_string(o.join("tags.csv")).unwrap();
    let rows: Vec<&str> = csv
        .lines()
        .filter(|l| !l.starts_with('#') && !l.starts_with("tag_id"))
        .collect();
    assert_eq!(rows.len(), n);
    assert!(rows.iter().all(|r| r.split(',').count() >= 10));
    let gj: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(o.join("tags.geojson")).unwrap()).unwrap();
    assert_eq!(gj["features"].as_array().unwrap().len(), n);
    let _: kml::Kml = std::fs::read_to_string(o.join("tags.kml"))
        .unwrap()
        .parse()
        .expect("KML parses");
    let g = gpx::read(std::io::BufReader::new(
        std::fs::File::open(o.join("tags.gpx")).unwrap(),
    ))
    .expect("GPX parses");
    assert_eq!(g.waypoints.len(), n);
    // The metadata (in the sidecar) names the coverage and the reach.
    let meta = std::fs::read_to_string(o.join("tags.meta.json")).unwrap();
    assert!(
        meta.contains("coverage") && meta.contains("network"),
        "{meta}"
    );
    assert!(meta.contains("reach_m"));
    // Every tag lies within the map's Helsinki extract (sanity of the
    // chainage → position conversion).
    for f in gj["features"].as_array().unwrap() {
        let c = &f["geometry"]["coordinates"];
        let (lon, lat) = (c[0].as_f64().unwrap(), c[1].as_f64().unwrap());
        assert!(
            (60.1..60.25).contains(&lat) && (24.8..25.1).contains(&lon),
            "{lat} {lon}"
        );
    }

    // Re-planning with the plan installed (its tags.csv as existing_tags):
    // every installed tag snaps back onto its own directed road (the best
    // fit as a lane-centre point among the roads within 15 m) and the walk
    // DP finds them sufficient, so nothing is added.
    let s2 = scenario_file(dir.path(), |t| {
        t.replace(
            "validation_runs = 100",
            &format!(
                "validation_runs = 0\nexisting_tags = \"{}\"",
                o.join("tags.csv").display()
            ),
        )
    });
    let scn2 = Scenario::load(&s2).unwrap();
    let set2 = PlannerSettings::from_scenario(&scn2).unwrap();
    let p2 = plan_network(&scn2, &set2, 1, false).unwrap();
    assert_eq!(p2.existing_kept, n);
    assert_eq!(p2.existing_off_network, 0);
    assert_eq!(p2.tag_count(), 0, "added {}", p2.tag_count());
    assert!(p2.verified);
}

#[test]
fn network_plan_is_verified_by_the_dp_and_not_below_its_bound() {
    let scn = Scenario::load(&repo("scenarios/helsinki-network-plan.toml")).unwrap();
    let s = PlannerSettings::from_scenario(&scn).unwrap();
    let net = scenario_network(&scn).unwrap();
    let p = plan_network_on(&scn, &s, &net).unwrap();
    let prob = p.problem.as_ref().unwrap();
    assert!(check(prob, &p.selected).feasible());
    assert!(p.verified);
    // Every directed edge's candidates are considered, and the plan only
    // uses candidates.
    assert_eq!(p.selected.len(), prob.sites.len());
    assert!(p.tag_count() >= p.lower_bound);
    // Dropping all tags of the plan leaves violations (the check can fail).
    let none = vec![false; prob.sites.len()];
    assert!(!check(prob, &none).feasible());
    // Tolerating no missed read needs fewer tags, and still verifies.
    let s0 = PlannerSettings {
        tolerate_missed_reads: 0,
        ..s.clone()
    };
    let p0 = plan_network_on(&scn, &s0, &net).unwrap();
    assert!(p0.verified);
    assert!(
        p0.tag_count() < p.tag_count(),
        "{} {}",
        p0.tag_count(),
        p.tag_count()
    );
    // Tags serve one direction: their positions are the lane centre, right
    // of travel on two-way roads (offset > 0), on the centreline of one-way
    // roads.
    for t in &p.tags {
        assert_eq!(t.oneway, t.lane_offset_m == 0.0);
        assert!(t.lane_offset_m <= 2.5);
    }
}

#[test]
fn network_coverage_bad_input_gives_clear_errors() {
    let dir = tempfile::tempdir().unwrap();
    // A motion-command route has no network.
    let motion = r#"name = "m"
requirement_m = 20.0
[[route]]
start = { lat = 60.0, lon = 24.0, height_m = 0.0, heading_deg = 0.0, speed_kmh = 36 }
motion = [ { kind = "cruise", duration_s = 60 } ]
[navigator]
mode = "integrated"
[aiding]
odometer = true
rfid = true
[planner]
coverage = "network"
"#;
    let p = dir.path().join("motion.toml");
    std::fs::write(&p, motion).unwrap();
    let scn = Scenario::load(&p).unwrap();
    let s = PlannerSettings::from_scenario(&scn).unwrap();
    let e = plan_network(&scn, &s, 1, false).unwrap_err().to_string();
    assert!(e.contains("needs a road map"), "{e}");
    let out = run(&["plan", p.to_str().unwrap(), "--out", "o"], dir.path());
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("needs a road map"), "{err}");
    assert!(!dir.path().join("o/plan.json").exists());

    // Empty and invalid maps.
    for (name, content, want) in [
        ("empty.osm.pbf", "", "empty"),
        ("bad.geojson", "{ not json", "json"),
        (
            "nothing.geojson",
            r#"{"type":"FeatureCollection","features":[]}"#,
            "empty",
        ),
    ] {
        let m = dir.path().join(name);
        std::fs::write(&m, content).unwrap();
        let sp = scenario_file(dir.path(), |t| {
            t.replace(
                repo("maps/helsinki.osm.pbf").to_str().unwrap(),
                m.to_str().unwrap(),
            )
        });
        let out = run(&["plan", sp.to_str().unwrap(), "--out", "o2"], dir.path());
        let err = String::from_utf8_lossy(&out.stderr).to_lowercase();
        assert!(!out.status.success(), "{name}");
        assert!(
            err.contains("waymark: error") && err.contains(want),
            "{name}: {err}"
        );
        assert!(!err.contains("panicked"), "{err}");
    }

    // Route-distance settings do not apply to networks.
    for (extra, want) in [
        ("forbidden_m = [[0, 100]]", "forbidden_m"),
        ("min_spacing_m = 30", "min_spacing_m"),
    ] {
        let sp = scenario_file(dir.path(), |t| {
            t.replace(
                "validation_runs = 100",
                &format!("validation_runs = 0\n{extra}"),
            )
        });
        let scn = Scenario::load(&sp).unwrap();
        let s = PlannerSettings::from_scenario(&scn).unwrap();
        let e = plan_network(&scn, &s, 1, false).unwrap_err().to_string();
        assert!(e.contains(want) && e.contains("network"), "{e}");
    }

    // A requirement below what a fix leaves, and one the candidate spacing
    // cannot meet: infeasibility reports naming roads.
    let sp = scenario_file(dir.path(), |t| {
        t.replace("requirement_m = 20.0", "requirement_m = 0.05")
    });
    let scn = Scenario::load(&sp).unwrap();
    let s = PlannerSettings::from_scenario(&scn).unwrap();
    let e = plan_network(&scn, &s, 1, false).unwrap_err().to_string();
    assert!(e.contains("below the best possible tag fix"), "{e}");
    // 0.3 m: above the ceiling fix, below the navigator's prior.
    let sp = scenario_file(dir.path(), |t| {
        t.replace("requirement_m = 20.0", "requirement_m = 0.3")
    });
    let scn = Scenario::load(&sp).unwrap();
    let s = PlannerSettings::from_scenario(&scn).unwrap();
    let e = plan_network(&scn, &s, 1, false).unwrap_err().to_string();
    assert!(
        e.contains("infeasible") && e.contains("initial position uncertainty"),
        "{e}"
    );
    let sp = scenario_file(dir.path(), |t| {
        t.replace("requirement_m = 20.0", "requirement_m = 5.0")
            .replace("candidate_spacing_m = 50", "candidate_spacing_m = 2000")
    });
    let scn = Scenario::load(&sp).unwrap();
    let s = PlannerSettings::from_scenario(&scn).unwrap();
    let e = plan_network(&scn, &s, 1, false).unwrap_err().to_string();
    assert!(e.contains("infeasible") && e.contains("road "), "{e}");
}

/// `plan --baseline` on a network plan: the validation's chains, runs and
/// seeds driven again without the planned tags (installed ones kept), and
/// the samples where the planner's own budget says tags are needed.
#[test]
fn network_plan_baseline_drives_the_same_chains_without_the_new_tags() {
    let dir = tempfile::tempdir().unwrap();
    let json = |p: &Path| -> serde_json::Value {
        serde_json::from_str(&std::fs::read_to_string(p).unwrap()).unwrap()
    };
    let ok = |out: &std::process::Output| {
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        String::from_utf8_lossy(&out.stdout).to_string()
    };
    let plan_args = |scn: &Path, out: &str, runs: &str| {
        run(
            &[
                "plan",
                scn.to_str().unwrap(),
                "--out",
                out,
                "--runs",
                runs,
                "--baseline",
            ],
            dir.path(),
        )
    };

    // A fresh trips plan with map matching: the baseline has no tag at all.
    // Helsinki's trips at 17 m: at 18 m and 20 m the plan has no tag, so
    // there would be no stretch to drive (and the Monaco map is not bundled
    // with the repo). 17 m is the loosest whole-metre requirement with tags
    // (5); it plans in 44 s where 15 m took 3 min (78 tags, its straight
    // walks forking past MAX_PATHS), which held the CI near its limit.
    let trips = std::fs::read_to_string(repo("scenarios/helsinki-network-trips.toml"))
        .unwrap()
        .replace(
            "../maps/helsinki.osm.pbf",
            repo("maps/helsinki.osm.pbf").to_str().unwrap(),
        )
        .replace("requirement_m = 20.0", "requirement_m = 17.0");
    assert!(trips.contains("requirement_m = 17.0"));
    let trips_path = dir.path().join("trips17.toml");
    std::fs::write(&trips_path, trips).unwrap();
    let stdout = ok(&plan_args(&trips_path, "t", "2"));
    assert!(stdout.contains("baseline: the same chains"), "{stdout}");
    assert!(
        stdout.contains("where the plan's model needs tags"),
        "{stdout}"
    );
    assert!(stdout.contains("over-budget stretches"), "{stdout}");
    let plan = json(&dir.path().join("t/plan.json"));
    let v = &plan["validation"];
    let b = &v["without_new_tags"];
    assert_eq!(b["tags"], 0, "{b}");
    // The same chains and runs: as many thinned samples.
    assert_eq!(b["thinned_samples"], v["thinned_samples"]);
    let over = v["over_budget_samples"].as_u64().unwrap();
    assert!(over <= v["thinned_samples"].as_u64().unwrap());
    assert!(v["over_budget_within"].as_u64().unwrap() <= over);
    assert!(b["over_budget_within"].as_u64().unwrap() <= over);
    // The stretches where the planner's budget without tags passes 1 (this
    // plan has tags, so its windows have such stretches): driven at least
    // 20 times each, one per directed section, samples over budget only.
    let st = &v["over_budget_stretches"];
    let n = st["stretches"].as_u64().unwrap();
    assert!((1..=8).contains(&n), "{st}");
    assert!(st["runs_per_stretch"].as_u64().unwrap() >= 20);
    assert!(st["peak_budget_min"].as_f64().unwrap() > 1.0);
    assert!(st["peak_budget_max"].as_f64().unwrap() >= st["peak_budget_min"].as_f64().unwrap());
    let (w, wo) = (&st["with_tags"], &st["without_new_tags"]);
    assert_eq!(w["thinned_samples"], wo["thinned_samples"]);
    assert!(w["thinned_samples"].as_u64().unwrap() >= 20 * n);
    // Where the budget passes 1 the plan puts its tags: with them read the
    // error there is far smaller than without (measured 1.44 m against
    // 12.69 m at 2 runs; a baseline that kept the tags would tie).
    let (ew, ewo) = (
        w["max_horizontal_error_m"].as_f64().unwrap(),
        wo["max_horizontal_error_m"].as_f64().unwrap(),
    );
    assert!(ew < 0.5 * ewo, "with tags {ew} m, without {ewo} m");

    // An any-walk plan (no map matching credit): no stretches, and its
    // tags installed for the next part.
    ok(&run(
        &[
            "plan",
            repo("scenarios/helsinki-network-plan.toml")
                .to_str()
                .unwrap(),
            "--out",
            "a",
            "--runs",
            "2",
        ],
        dir.path(),
    ));
    let plan = json(&dir.path().join("a/plan.json"));
    assert!(plan["validation"]["without_new_tags"].is_null());

    // Re-planned with that plan installed: no new tag, so the baseline
    // keeps every tag and must reproduce the validation exactly (same
    // chains, runs and seeds).
    let s2 = scenario_file(dir.path(), |t| {
        t.replace(
            "validation_runs = 100",
            &format!(
                "existing_tags = \"{}\"",
                dir.path().join("a/tags.csv").display()
            ),
        )
    });
    ok(&plan_args(&s2, "b", "2"));
    let plan2 = json(&dir.path().join("b/plan.json"));
    assert_eq!(plan2["tag_count"], 0);
    let v2 = &plan2["validation"];
    let b2 = &v2["without_new_tags"];
    assert_eq!(b2["tags"], plan2["existing_kept"]);
    assert!(b2["tags"].as_u64().unwrap() > 0);
    for k in [
        "fraction_within_requirement",
        "thinned_within",
        "median_run_max_m",
        "max_horizontal_error_m",
        "runs_exceeding",
    ] {
        assert_eq!(b2[k], v2[k], "{k}");
    }
    assert_eq!(b2["over_budget_within"], v2["over_budget_within"]);
    assert!(
        v2["over_budget_stretches"].is_null(),
        "any walk: no stretches"
    );

    // Without validation runs there is nothing to compare: one error line.
    let out = plan_args(&repo("scenarios/helsinki-network-plan.toml"), "c", "0");
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("--baseline") && err.contains("--runs 0"),
        "{err}"
    );
    assert_eq!(err.trim_end().lines().count(), 1, "{err}");
    assert!(!dir.path().join("c/plan.json").exists());
}
