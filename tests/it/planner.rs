//! The tag planner: `waymark plan` as a real binary on the bundled Helsinki
//! map, the library's budget and placement on the same route, and bad input.

use crate::common;

use common::{repo, run};

use waymark::planner::Budget;
use waymark::planner::{plan_with, PlannerSettings};
use waymark::sim::{Scenario, TruthSource};
use waymark::tags::TagPayload;

fn scenario_with(name: &str, edit: impl Fn(String) -> String) -> Scenario {
    let path = repo(name);
    let text = edit(std::fs::read_to_string(&path).unwrap());
    Scenario::parse(&path, &text).unwrap()
}

#[test]
fn plan_cli_on_helsinki_writes_validated_plan_and_exports() {
    let dir = tempfile::tempdir().unwrap();
    let scn = repo("scenarios/helsinki-plan-mems.toml");
    let out = run(
        &[
            "plan",
            scn.to_str().unwrap(),
            "--out",
            "out",
            "--runs",
            "30",
        ],
        dir.path(),
    );
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}\n{}",
        stdout,
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(stdout.contains("validation: 30 run(s)"), "{stdout}");
    let o = dir.path().join("out");
    let plan: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(o.join("plan.json")).unwrap()).unwrap();
    let n = plan["tag_count"].as_u64().unwrap();
    // Without tags the predicted bound leaves 20 m; the plan needs some.
    assert!(n >= 2, "{plan}");
    assert_eq!(plan["requirement_m"].as_f64(), Some(20.0));
    // The lower bound brackets the count; "optimal" says whether they meet.
    let lb = plan["lower_bound"].as_u64().unwrap();
    assert!(lb <= n, "{plan}");
    assert_eq!(plan["optimal"].as_bool(), Some(lb == n));
    let method = plan["method"].as_str().unwrap();
    assert!(
        method.starts_with("exact") || method.starts_with("forward"),
        "{method}"
    );
    assert!(plan["predicted_max_bound95_m"].as_f64().unwrap() <= 20.0);
    let v = &plan["validation"];
    assert_eq!(v["runs"].as_u64(), Some(30));
    let frac = v["fraction_within_requirement"].as_f64().unwrap();
    assert!(frac >= 0.99, "{v}");
    assert!(v["max_horizontal_error_m"].as_f64().unwrap() > 0.0);
    // tags.csv: the simulator's own reader takes it; payloads decode to the rows.
    let csv = o.join("tags.csv");
    let tags = waymark::sim::tags::load_tags_csv(&csv).unwrap();
    assert_eq!(tags.len() as u64, n);
    let text = std::fs::read_to_string(&csv).unwrap();
    // The first line is the header; the metadata is in the sidecar.
    assert!(text.starts_with("tag_id,"), "{text}");
    let meta: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(o.join("tags.meta.json")).unwrap()).unwrap();
    assert_eq!(meta["requirement_m"], 20.0);
    let mut rdr = csv::ReaderBuilder::new().from_reader(text.as_bytes());
    let h = rdr.headers().unwrap().clone();
    let col = |name: &str| h.iter().position(|c| c == name).unwrap();
    for r in rdr.records() {
        let r = r.unwrap();
        let p = TagPayload::from_hex(&r[col("payload_hex")]).unwrap();
        let lat: f64 = r[col("lat")].parse().unwrap();
        let lon: f64 = r[col("lon")].parse().unwrap();
        assert!((p.lat_deg - lat).abs() < 2e-6 && (p.lon_deg - lon).abs() < 2e-6);
        assert_eq!(p.mounting.as_str(), &r[col("mounting")]);
        assert!(!r[col("road_id")].is_empty());
    }
    for f in ["tags.geojson", "tags.kml", "tags.gpx"] {
        assert!(o.join(f).exists(), "{f}");
    }
    let gj: geojson::GeoJson = std::fs::read_to_string(o.join("tags.geojson"))
        .unwrap()
        .parse()
        .unwrap();
    match gj {
        geojson::GeoJson::FeatureCollection(fc) => assert_eq!(fc.features.len() as u64, n),
        _ => panic!("not a FeatureCollection"),
    }
    let _: kml::Kml = std::fs::read_to_string(o.join("tags.kml"))
        .unwrap()
        .parse()
        .expect("KML parses");
    let g = gpx::read(std::io::BufReader::new(
        std::fs::File::open(o.join("tags.gpx")).unwrap(),
    ))
    .expect("GPX parses");
    assert_eq!(g.waypoints.len() as u64, n);
}

#[test]
fn plan_holds_with_any_single_missed_tag_and_budget_resets_at_fixes() {
    let scn = Scenario::load(&repo("scenarios/helsinki-plan-mems.toml")).unwrap();
    let truth = TruthSource::new(&scn).unwrap();
    let settings = PlannerSettings::from_scenario(&scn).unwrap();
    assert_eq!(settings.tolerate_missed_reads, 1);
    let plan = plan_with(&scn, &truth, &settings, 1, false).unwrap();
    let req = settings.requirement_m;
    // Without tags the predicted bound exceeds the requirement; with them it does not.
    let without = plan
        .profile_without_tags
        .iter()
        .map(|p| p.bound95_m)
        .fold(0.0, f64::max);
    assert!(without > req, "{without}");
    assert!(plan.predicted_max_bound95_m <= req);
    // The bound grows between fixes: the tag-free profile rises overall.
    let first = plan.profile_without_tags[1].bound95_m;
    let last = plan.profile_without_tags.last().unwrap().bound95_m;
    assert!(last > 3.0 * first, "{first} {last}");
    // A fix resets the bound to about the fix error.
    for t in &plan.tags {
        assert!(t.bound_after_fix_m < 1.0, "{t:?}");
    }
    // Each tag's road chainage (what installers measure) puts it where the
    // tag is: walk the road's sections to the chainage; the tag is in the
    // truth's lane (issue 12), so within the carriageway's half width of
    // that centre-line point, plus 1 m.
    let net0 = waymark::Network::load(&repo("maps/helsinki.osm.pbf"), &Default::default()).unwrap();
    for t in &plan.tags {
        let id = t.road_id.as_deref().unwrap();
        let road = net0
            .model
            .roads
            .iter()
            .find(|r| r.attributes.id == id)
            .unwrap();
        let mut left = t.road_chainage_m.unwrap();
        assert!(left >= 0.0 && left <= road.length_m + 1e-6, "{t:?}");
        let mut at = None;
        for &sec in &road.sections {
            let len = net0.sections[sec as usize].length_m;
            if left <= len + 1e-9 {
                let g = net0
                    .section_segments(sec)
                    .iter()
                    .find(|g| g.section_offset_m + g.length_m >= left - 1e-9)
                    .unwrap();
                let u = ((left - g.section_offset_m) / g.length_m).clamp(0.0, 1.0);
                at = Some([
                    g.a[0] + u * (g.b[0] - g.a[0]),
                    g.a[1] + u * (g.b[1] - g.a[1]),
                ]);
                break;
            }
            left -= len;
        }
        let p = at.unwrap();
        let g = net0.frame.to_geodetic([p[0], p[1], 0.0]);
        let (rm, rn) = waymark::geodesy::radii(t.lat.to_radians());
        let de = (g.lon_deg() - t.lon).to_radians() * rn * t.lat.to_radians().cos();
        let dn = (g.lat_deg() - t.lat).to_radians() * rm;
        let a = &road.attributes;
        let half = 0.5
            * f64::from(waymark::network::carriageway_lanes(a))
            * waymark::network::lane_width_m(a);
        assert!(
            de.hypot(dn) < half + 1.0,
            "{t:?}: {} m off (half width {half} m)",
            de.hypot(dn)
        );
    }
    // Drop each tag in turn (a missed read): the predicted bound, propagated
    // by the filter with the remaining fixes, still holds.
    let net = waymark::Network::load(&repo("maps/helsinki.osm.pbf"), &Default::default()).unwrap();
    let budget = Budget::new(&scn, &truth, Some(&net));
    let fixes: Vec<(usize, waymark::tags::Mounting)> = plan
        .tags
        .iter()
        .map(|t| {
            let i = budget
                .samples()
                .iter()
                .position(|s| s.avp.distance_m >= t.route_distance_m - 1e-6)
                .unwrap();
            (i, t.mounting)
        })
        .collect();
    for drop in 0..fixes.len() {
        let mut f = fixes.clone();
        f.remove(drop);
        let worst = budget
            .with_fixes(&f, 20.0)
            .iter()
            .map(|p| p.bound95_m)
            .fold(0.0, f64::max);
        assert!(worst <= req, "tag {drop} missed: {worst}");
    }
    // And dropping two consecutive tags (more than tolerated) breaks it,
    // or the plan has fewer than two tags: minimality has teeth.
    if fixes.len() >= 2 {
        let mut broke = false;
        for d in 0..fixes.len() - 1 {
            let mut f = fixes.clone();
            f.drain(d..d + 2);
            let worst = budget
                .with_fixes(&f, 20.0)
                .iter()
                .map(|p| p.bound95_m)
                .fold(0.0, f64::max);
            broke |= worst > req;
        }
        assert!(
            broke,
            "no pair of missed tags matters: the plan is not minimal"
        );
    }
}

#[test]
fn requirement_below_best_fix_is_a_clear_error() {
    let scn = scenario_with("scenarios/helsinki-plan-mems.toml", |t| {
        t.replace("requirement_m = 20.0", "requirement_m = 0.3")
    });
    let truth = TruthSource::new(&scn).unwrap();
    let s = PlannerSettings::from_scenario(&scn).unwrap();
    let e = plan_with(&scn, &truth, &s, 1, false)
        .unwrap_err()
        .to_string();
    assert!(e.contains("below the best possible tag fix"), "{e}");
}

#[test]
fn forbidden_zone_makes_an_infeasibility_report_naming_the_stretch() {
    let scn = scenario_with("scenarios/helsinki-plan-mems.toml", |t| {
        t.replace(
            "validation_runs = 100",
            "validation_runs = 100\nforbidden_m = [[100, 5000]]",
        )
    });
    let truth = TruthSource::new(&scn).unwrap();
    let s = PlannerSettings::from_scenario(&scn).unwrap();
    let e = plan_with(&scn, &truth, &s, 1, false)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("infeasible") && e.contains("cannot be covered"),
        "{e}"
    );
    assert!(e.contains("road "), "{e}");
}

#[test]
fn bad_planner_settings_are_rejected() {
    for (from, to, want) in [
        (
            "tolerate_missed_reads = 1",
            "tolerate_missed_reads = 1\ncoverage = \"everything\"",
            "not one of routes, network",
        ),
        (
            "mountings = [\"road_surface\", \"roadside\"]",
            "mountings = [\"road_surface\", \"ceilling\"]",
            "ceilling",
        ),
        (
            "validation_runs = 100",
            "validation_runs = 100\ncandidate_spacing_m = 0.1",
            "candidate_spacing_m",
        ),
    ] {
        // The planner's options are validated with the scenario: loading fails.
        let path = repo("scenarios/helsinki-plan-mems.toml");
        let text = std::fs::read_to_string(&path).unwrap().replace(from, to);
        let e = Scenario::parse(&path, &text).unwrap_err().to_string();
        assert!(e.contains(want), "{e}");
    }
}

#[test]
fn bad_per_mounting_read_probability_is_a_clear_cli_error() {
    // An impossible probability: one line naming the file and the field,
    // exit 1, no panic, no output folder.
    let dir = tempfile::tempdir().unwrap();
    let map = repo("maps/helsinki.osm.pbf");
    let text = std::fs::read_to_string(repo("scenarios/helsinki-plan-mems.toml"))
        .unwrap()
        .replace("../maps/helsinki.osm.pbf", map.to_str().unwrap())
        .replace(
            "read_probability = 0.977",
            "read_probability = 0.977\nread_probability_roadside = 1.5",
        );
    std::fs::write(dir.path().join("bad.toml"), text).unwrap();
    let out = run(&["plan", "bad.toml", "--out", "o"], dir.path());
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(
        err.contains("bad.toml") && err.contains("rfid.read_probability_roadside"),
        "{err}"
    );
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    assert!(!err.contains("panicked"), "{err}");
    assert!(!dir.path().join("o").exists());
}

#[test]
fn route_leaving_the_map_is_an_error() {
    let dir = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(repo("scenarios/helsinki-plan-mems.toml"))
        .unwrap()
        .replace(
            "../maps/helsinki.osm.pbf",
            repo("maps/helsinki.osm.pbf").to_str().unwrap(),
        )
        .replace("[60.1660, 24.9380]]", "[60.3000, 25.3000]]");
    let p = dir.path().join("s.toml");
    std::fs::write(&p, text).unwrap();
    let out = run(&["plan", p.to_str().unwrap(), "--out", "o"], dir.path());
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("waymark: error"), "{err}");
    assert!(!dir.path().join("o/plan.json").exists());
}

#[test]
fn existing_tags_are_kept_and_bad_rows_are_named() {
    let scn = Scenario::load(&repo("scenarios/helsinki-plan-mems.toml")).unwrap();
    let truth = TruthSource::new(&scn).unwrap();
    let mut settings = PlannerSettings::from_scenario(&scn).unwrap();
    let first = plan_with(&scn, &truth, &settings, 1, false).unwrap();
    assert!(first.tag_count() >= 2);
    // The first plan's tags, installed: nothing new is needed.
    settings.existing_tags = first.sim_tags();
    let again = plan_with(&scn, &truth, &settings, 1, false).unwrap();
    assert_eq!(again.tag_count(), 0, "{:?}", again.tags);
    assert_eq!(again.existing_count(), first.tag_count());
    assert!(again.predicted_max_bound95_m <= 20.0);
    // Only the first one installed: the plan adds the rest, never fewer
    // in total than the minimum.
    settings.existing_tags = first.sim_tags()[..1].to_vec();
    let part = plan_with(&scn, &truth, &settings, 1, false).unwrap();
    assert_eq!(part.existing_count(), 1);
    assert!(part.tag_count() + 1 >= first.tag_count());
    assert!(part.predicted_max_bound95_m <= 20.0);
    // A file with a bad row: the error names the file and the line.
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("installed.csv"),
        "tag_id,lat,lon,mounting\nA,60.17,24.94,road_surface\nB,north,24.95,road_surface\n",
    )
    .unwrap();
    let text = std::fs::read_to_string(repo("scenarios/helsinki-plan-mems.toml"))
        .unwrap()
        .replace(
            "../maps/helsinki.osm.pbf",
            repo("maps/helsinki.osm.pbf").to_str().unwrap(),
        )
        .replace(
            "validation_runs = 100",
            "validation_runs = 100\nexisting_tags = \"installed.csv\"",
        );
    let p = dir.path().join("s.toml");
    std::fs::write(&p, &text).unwrap();
    let scn = Scenario::load(&p).unwrap();
    let e = PlannerSettings::from_scenario(&scn)
        .unwrap_err()
        .to_string();
    assert!(e.contains("installed.csv") && e.contains("line 3"), "{e}");
}

/// A short MEMS drive with turns (no map), small enough to enumerate every
/// set of candidate sites.
fn small_mems_scenario(k: usize, requirement_m: f64, spacing_m: f64) -> Scenario {
    let text = format!(
        r#"
name = "small-mems"
requirement_m = {requirement_m}
[[route]]
start = {{ lat = 60.0, lon = 25.0, height_m = 10.0, heading_deg = 0.0 }}
motion = [ {{ kind = "accelerate", to_kmh = 50, accel_mps2 = 1.0 }},
           {{ kind = "cruise", distance_m = 1200 }},
           {{ kind = "turn", angle_deg = 90, radius_m = 30 }},
           {{ kind = "cruise", distance_m = 1500 }},
           {{ kind = "turn", angle_deg = -90, radius_m = 30 }},
           {{ kind = "cruise", distance_m = 1300 }} ]
[navigator]
mode = "integrated"
[imu]
rate_hz = 50
gyro_bias_dph = [10, 10, 10]
accel_bias_ug = [1000, 1000, 1000]
gyro_arw_dprh = 0.3
accel_vrw_ugprhz = 100
[aiding]
odometer = false
non_holonomic = true
baro = true
rfid = true
[planner]
tolerate_missed_reads = {k}
mountings = ["roadside"]
candidate_spacing_m = {spacing_m}
"#
    );
    Scenario::parse(&repo("scenarios/small-mems.toml"), &text).unwrap()
}

/// Minimality on one route, against brute force with the real filter: every
/// set of candidate sites with fewer tags than the plan fails the covariance
/// check (bound within the requirement with all read and with any k
/// consecutive tags missed), the plan passes it, and the reported lower
/// bound is at most the true minimum.
#[test]
fn plan_is_minimal_against_brute_force_with_the_filter() {
    // With one missed read tolerated the reach must span two candidate
    // spacings (the first two sites within the start's reach, about 650 m
    // at 40 m), hence the looser requirement and closer sites there.
    for (k, req, spacing) in [(0usize, 20.0, 400.0), (1, 40.0, 300.0)] {
        let scn = small_mems_scenario(k, req, spacing);
        let truth = TruthSource::new(&scn).unwrap();
        let settings = PlannerSettings::from_scenario(&scn).unwrap();
        let plan = plan_with(&scn, &truth, &settings, 1, false).unwrap();
        let budget = Budget::new(&scn, &truth, None);
        let spacing = settings.candidate_spacing_m;
        let length = budget.length_m();
        let mut at = vec![];
        let mut d = spacing;
        while d < length {
            at.push(d);
            d += spacing;
        }
        let (_, sites) = budget.tag_free(spacing, &at);
        let m = waymark::tags::Mounting::Roadside;
        let ok = |set: &[usize]| {
            let fixes: Vec<_> = set.iter().map(|&i| (sites[i].sample, m)).collect();
            waymark::planner::robust(&budget, &fixes, k, settings.requirement_m, spacing)
        };
        // The plan's tags are candidate sites; it passes the check.
        let idx: Vec<usize> = plan
            .tags
            .iter()
            .map(|t| {
                sites
                    .iter()
                    .position(|s| (s.distance_m - t.route_distance_m).abs() < 1e-6)
                    .expect("plan tags are candidate sites")
            })
            .collect();
        assert!(ok(&idx), "k = {k}: the plan fails its own check");
        let n = idx.len();
        assert!(n >= 1, "k = {k}: the route needs tags");
        // No smaller subset of the candidates passes (all of them enumerated).
        let c = sites.len();
        assert!(c <= 16, "{c} candidates: too many to enumerate");
        let mut min = usize::MAX;
        for mask in 0u32..(1 << c) {
            let size = mask.count_ones() as usize;
            if size >= min.min(n) {
                continue;
            }
            let set: Vec<usize> = (0..c).filter(|i| mask & (1 << i) != 0).collect();
            if ok(&set) {
                min = min.min(size);
            }
        }
        assert_eq!(min, usize::MAX, "k = {k}: a set of {min} < {n} tags passes");
        assert!(
            plan.lower_bound <= n,
            "k = {k}: lower bound {}",
            plan.lower_bound
        );
        eprintln!(
            "k = {k}: {c} candidates, plan {n} tags ({}), lower bound {}",
            plan.method, plan.lower_bound
        );
    }
}

/// The uniform baseline is held to the plan's standard, and its sites are
/// candidate sites, so the (minimal) plan can never need more tags than it.
#[test]
fn uniform_baseline_passes_the_plans_check_and_never_beats_the_plan() {
    let scn = small_mems_scenario(0, 20.0, 400.0);
    let truth = TruthSource::new(&scn).unwrap();
    let settings = PlannerSettings::from_scenario(&scn).unwrap();
    let plan = plan_with(&scn, &truth, &settings, 1, false).unwrap();
    let b = waymark::planner::uniform_baseline(&scn, &truth, &settings, 5, 1, 0.99)
        .unwrap()
        .expect("tags at every candidate site pass");
    assert_eq!(b.tolerate_missed_reads, 0);
    assert!(b.validation.fraction_within_requirement >= 0.99, "{b:?}");
    assert!(
        b.tag_count >= plan.tag_count(),
        "{b:?} vs {}",
        plan.tag_count()
    );
    assert!(b.spacing_m >= settings.candidate_spacing_m);
    // The next longer spacing tried fails (the search found the largest).
    let longer = b
        .tried
        .iter()
        .find(|(s, _)| *s > b.spacing_m)
        .map(|&(_, f)| f);
    if let Some(f) = longer {
        assert!(f.is_nan() || f < 0.99, "{:?}", b.tried);
    }
}

#[test]
fn uniform_baseline_tags_are_numbered_around_the_scenarios_tag_ids() {
    // A [[tag]] named U0002 (say, a tag of an earlier baseline kept in the
    // scenario): the baseline's tags, simulated beside it in the baseline's
    // validation, skip its id; before, the second baseline tag was U0002 too
    // and the two tags' reads could not be told apart.
    let scn = scenario_with("scenarios/helsinki-plan-mems.toml", |t| {
        t + "\n[[tag]]\nid = \"U0002\"\nat_m = 100\n"
    });
    let truth = TruthSource::new(&scn).unwrap();
    let settings = PlannerSettings::from_scenario(&scn).unwrap();
    let tags = waymark::planner::uniform_tags(&truth, &scn, &settings, 500.0);
    let ids: Vec<&str> = tags.iter().map(|t| t.id.as_str()).collect();
    assert!(ids.len() >= 3, "{ids:?}");
    assert_eq!(&ids[..3], ["U0001", "U0003", "U0004"], "{ids:?}");
}
