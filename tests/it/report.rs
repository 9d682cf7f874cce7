//! `waymark report` on a real simulate folder: a self-contained HTML file and
//! PNG plots that are not blank; and, where Chromium is installed, the page
//! rendered in headless Chromium with no console errors.

use std::path::{Path, PathBuf};
use std::process::Command;

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_waymark"))
}

fn simulate_and_report(dir: &Path) -> PathBuf {
    let scn = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenarios/helsinki-route-dr.toml");
    let out = dir.join("hel");
    let s = bin()
        .args([
            "simulate",
            scn.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ])
        .output()
        .unwrap();
    assert!(s.status.success(), "{}", String::from_utf8_lossy(&s.stderr));
    let r = bin()
        .args(["report", out.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    out
}

/// Share of pixels that are not (near) white.
fn ink_share(png_bytes: &[u8]) -> f64 {
    let decoder = png::Decoder::new(std::io::Cursor::new(png_bytes));
    let mut reader = decoder.read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size()];
    let info = reader.next_frame(&mut buf).unwrap();
    let channels = info.color_type.samples();
    let px = &buf[..info.buffer_size()];
    let n = px.len() / channels;
    let inked = px
        .chunks_exact(channels)
        .filter(|p| p[..3].iter().any(|&c| c < 200))
        .count();
    inked as f64 / n as f64
}

#[test]
fn report_is_self_contained_and_plots_are_drawn() {
    let dir = tempfile::tempdir().unwrap();
    let out = simulate_and_report(dir.path());
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    assert!(html.starts_with("<!DOCTYPE html>"));
    assert!(html.contains("<svg"), "plots are inline SVG");
    // The verdict under the planner's rule, decided on the thinned samples
    // summary.json records: one run of a few minutes is too few samples to
    // be sure of 95 % (the lower bound of n of n is 0.05^(1/n) < 0.95 for
    // n < 59), so the page cannot be green however small the error.
    let summary: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("summary.json")).unwrap()).unwrap();
    let rule = &summary["requirement_rule"];
    let (n, within) = (
        rule["thinned_samples"].as_u64().unwrap(),
        rule["thinned_within"].as_u64().unwrap(),
    );
    let duration = summary["duration_s"].as_f64().unwrap();
    assert_eq!(
        n,
        (duration / 30.0).floor() as u64 + 1,
        "one sample per 30 s"
    );
    assert_eq!(rule["requirement_confidence"].as_f64(), Some(0.95));
    let level = if rule["passed"].as_bool().unwrap() {
        "green"
    } else if within as f64 >= 0.95 * n as f64 {
        "amber"
    } else {
        "red"
    };
    assert_eq!(
        level == "green",
        0.05f64.powf(1.0 / n as f64) >= 0.95 && within == n
    );
    assert!(
        html.contains(&format!("data-level=\"{level}\">Simulation")),
        "verdict {level} shown"
    );
    // The rule's words (printed by simulate, in summary.json) end as the
    // page's level does: not "FAILED" where the page says amber.
    let words = rule["rule"].as_str().unwrap();
    let expected_end = match level {
        "green" => "passed",
        "amber" => "(run more)",
        _ => "FAILED",
    };
    assert!(words.ends_with(expected_end), "{level}: {words}");
    assert!(
        html.contains(&format!("{within} of {n} thinned samples within 10 m")),
        "the figures the verdict was decided on"
    );
    assert!(
        html.contains("Rule (the planner&apos;s validation rule")
            || html.contains("Rule (the planner's validation rule"),
        "the rule is stated"
    );
    // The map of the scenario's area, redrawn from the scenario recorded by simulate.
    assert!(html.contains("<h2>Map</h2>"), "map section");
    assert!(
        html.matches("<polyline").count() > 500,
        "the Helsinki roads are drawn"
    );
    assert!(html.contains("<h2>Scenario</h2>"), "scenario shown");
    // One script, the project's own, inline: nothing loaded.
    assert_eq!(html.matches("<script").count(), 1, "one inline script");
    assert!(!html.contains("<script src"), "no external script");
    // No external resources: the only URLs are XML namespaces.
    for (i, _) in html.match_indices("http") {
        let tail = &html[i..(i + 40).min(html.len())];
        assert!(
            tail.starts_with("http://www.w3.org/"),
            "external reference: {tail}"
        );
    }
    for png in ["error_time.png", "error_distance.png"] {
        let bytes = std::fs::read(out.join("plots").join(png)).unwrap();
        let ink = ink_share(&bytes);
        // Axes, grid, labels and the curve: a few percent of the pixels, not none
        // and not a filled canvas.
        assert!(ink > 0.01 && ink < 0.5, "{png}: ink share {ink}");
    }
}

#[test]
fn monte_carlo_report_shows_the_filter_bound_and_the_envelope() {
    let dir = tempfile::tempdir().unwrap();
    let scn =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("scenarios/helsinki-route-integrated.toml");
    let out = dir.path().join("mc");
    let s = bin()
        .args([
            "simulate",
            scn.to_str().unwrap(),
            "--runs",
            "6",
            "--out",
            out.to_str().unwrap(),
        ])
        .output()
        .unwrap();
    assert!(s.status.success(), "{}", String::from_utf8_lossy(&s.stderr));
    let r = bin()
        .args(["report", out.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    for label in [
        "filter 95 % bound",
        "median over runs",
        "95th percentile over runs",
        "max over runs",
    ] {
        assert!(html.contains(label), "missing legend entry '{label}'");
    }
}

fn chromium() -> Option<PathBuf> {
    [
        "/usr/bin/chromium",
        "/usr/bin/chromium-browser",
        "/usr/bin/google-chrome",
    ]
    .iter()
    .map(PathBuf::from)
    .find(|p| p.exists())
}

/// Runs headless Chromium on `page`: the DOM after the page's script ran,
/// and a screenshot at `shot` (1200 px wide, `height` tall). Panics on
/// console output (errors included).
fn render(browser: &Path, page: &Path, shot: &Path, profile: &Path, height: u32) -> String {
    let common = |extra: &[String]| {
        let mut args: Vec<String> = [
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--no-first-run",
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
            "--hide-scrollbars",
            "--enable-logging=stderr",
            "--v=0",
        ]
        .iter()
        .map(|s| s.to_string())
        .collect();
        args.push(format!("--user-data-dir={}", profile.display()));
        args.extend_from_slice(extra);
        args.push(format!("file://{}", page.display()));
        let run = Command::new(browser).args(&args).output().unwrap();
        let log = String::from_utf8_lossy(&run.stderr).into_owned();
        assert!(run.status.success(), "chromium failed: {log}");
        // Console messages are logged as "CONSOLE(line)": the page's own
        // script logs nothing, so any (errors included) means a fault.
        let console: Vec<&str> = log.lines().filter(|l| l.contains("CONSOLE")).collect();
        assert!(console.is_empty(), "console output: {console:?}");
        String::from_utf8_lossy(&run.stdout).into_owned()
    };
    common(&[
        format!("--screenshot={}", shot.display()),
        format!("--window-size=1200,{height}"),
    ]);
    let ink = ink_share(&std::fs::read(shot).unwrap());
    assert!(ink > 0.02, "screenshot looks blank (ink share {ink})");
    common(&["--dump-dom".into(), "--virtual-time-budget=2000".into()])
}

/// Checks a rendered report: the map's script ran, every tag is drawn and
/// has a row in the tag table, and no number is NaN.
fn check_rendered(dom: &str, tags_csv: &Path) {
    let tags = std::fs::read_to_string(tags_csv).unwrap().lines().count() - 1;
    assert!(
        dom.contains("data-map-script=\"ready\""),
        "the map's script did not run"
    );
    if tags == 0 {
        // A plan without tags says so instead of listing none.
        assert!(dom.contains("id=\"no-tags\""), "no word on the plan's tags");
        assert!(
            !dom.contains("class=\"tag\""),
            "a tag drawn that the plan has not"
        );
        assert!(!dom.contains("NaN"), "NaN on the page");
        return;
    }
    let table = &dom[dom.find("id=\"tag-table\"").expect("tag table")..];
    let body = &table[table.find("<tbody>").unwrap()..table.find("</tbody>").unwrap()];
    assert_eq!(body.matches("<tr").count(), tags, "one table row per tag");
    assert!(
        dom.matches("class=\"tag\"").count() >= tags,
        "every tag drawn on the map"
    );
    assert!(!dom.contains("NaN"), "NaN on the page");
    assert!(!dom.contains(">—<"), "a dash where a number belongs");
}

#[test]
fn report_renders_in_headless_chromium() {
    let Some(browser) = chromium() else {
        // .ci/run installs Chromium and sets WAYMARK_REQUIRE_BROWSER=1, so CI
        // cannot skip this; a developer machine without it can.
        assert!(
            std::env::var_os("WAYMARK_REQUIRE_BROWSER").is_none(),
            "WAYMARK_REQUIRE_BROWSER is set but Chromium is not installed"
        );
        eprintln!("skipping: Chromium not installed");
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let target = Path::new(env!("CARGO_MANIFEST_DIR")).join("target");
    std::fs::create_dir_all(&target).unwrap();
    // The demo's report (a route): plan, validation, map with the tags, plots.
    let out = dir.path().join("demo");
    let d = bin()
        .args(["demo", "--out", out.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(d.status.success(), "{}", String::from_utf8_lossy(&d.stderr));
    let dom = render(
        &browser,
        &out.join("report.html"),
        &target.join("report-screenshot.png"),
        &dir.path().join("profile-a"),
        1800,
    );
    check_rendered(&dom, &out.join("tags.csv"));
    assert!(dom.contains("data-info=\"start\"") && dom.contains("class=\"north\""));
    // The README's picture of the demo's report is this screenshot:
    // WAYMARK_UPDATE_DOCS=1 cargo test --release --test it report:: renews it.
    if std::env::var_os("WAYMARK_UPDATE_DOCS").is_some() {
        std::fs::copy(
            target.join("report-screenshot.png"),
            Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/demo-report.png"),
        )
        .unwrap();
    }
    // An area plan's report (for traffic, so with the planner's
    // coverage.geojson): the whole network, every tag, the roads coloured
    // by their predicted bound with a colour bar.
    let net = dir.path().join("net");
    let scn = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenarios/helsinki-network-trips.toml");
    let p = bin()
        .args([
            "plan",
            scn.to_str().unwrap(),
            "--runs",
            "4",
            "--out",
            net.to_str().unwrap(),
        ])
        .output()
        .unwrap();
    assert!(p.status.success(), "{}", String::from_utf8_lossy(&p.stderr));
    let r = bin()
        .args(["report", net.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let dom = render(
        &browser,
        &net.join("report.html"),
        &target.join("report-network-screenshot.png"),
        &dir.path().join("profile-b"),
        // Tall enough for the coloured map below the plan's tables.
        4200,
    );
    check_rendered(&dom, &net.join("tags.csv"));
    assert!(dom.contains("lower bound on new tags") && dom.contains("reach between fixes"));
    assert!(net.join("coverage.geojson").exists());
    let cov = &dom[dom
        .find("class=\"coverage\"")
        .expect("roads coloured by their bound")..];
    assert!(
        cov[..cov.find("</g>").unwrap()]
            .matches("<polyline")
            .count()
            > 100
    );
    assert!(dom.contains("class=\"colour-bar\""));
    assert!(dom.contains("data-level=\"") && dom.contains("thinned samples within 20 m"));
}

#[test]
fn map_draws_every_section_the_route_and_the_tags() {
    use waymark::network::{LoadOptions, Network};
    use waymark::report::{map_svg, MapOverlay, MapTag};
    use waymark::tags::Mounting;
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("maps/helsinki.osm.pbf");
    let net = Network::load(&p, &LoadOptions::default()).unwrap();
    let route =
        waymark::route::plan_route(&net, &[[60.1660, 24.9380], [60.1770, 24.9510]]).unwrap();
    let n = route.vertices.len();
    let overlay = MapOverlay {
        route: route
            .vertices
            .iter()
            .enumerate()
            .map(|(i, v)| {
                (
                    v.lat_lon,
                    if i < n / 5 {
                        0.0
                    } else {
                        30.0 * i as f64 / n as f64
                    },
                )
            })
            .collect(),
        tags: vec![
            MapTag {
                lat_lon: route.vertices[n / 3].lat_lon,
                mounting: Mounting::Roadside,
                info: "A".into(),
            },
            MapTag {
                lat_lon: route.vertices[2 * n / 3].lat_lon,
                mounting: Mounting::Ceiling,
                info: "B".into(),
            },
            // 1 m from B: drawn apart, each with a leader to its place.
            MapTag {
                lat_lon: [
                    route.vertices[2 * n / 3].lat_lon[0] + 1e-5,
                    route.vertices[2 * n / 3].lat_lon[1],
                ],
                mounting: Mounting::RoadSurface,
                info: "C".into(),
            },
        ],
        requirement_m: Some(20.0),
        ..Default::default()
    };
    let svg = map_svg(&net, &overlay, 900);
    // The view is fitted to the route: sections far from it are left out.
    let drawn = svg.matches("<polyline").count();
    assert!(
        drawn > 100 && drawn <= net.sections.len(),
        "{drawn} of {} sections",
        net.sections.len()
    );
    assert_eq!(
        svg.matches("<line ").count(),
        n - 1 + 1,
        "route segments plus the leader of the tag moved off B"
    );
    assert_eq!(svg.matches("<circle").count(), 3);
    let centre = |info: &str| {
        let i = svg.find(&format!("data-info=\"{info}\"")).unwrap();
        let c = &svg[svg[..i].rfind("<circle").unwrap()..i];
        let num = |k: &str| -> f64 {
            let j = c.find(k).unwrap() + k.len();
            c[j..].split('"').next().unwrap().parse().unwrap()
        };
        (num("cx=\""), num("cy=\""))
    };
    let (b, c) = (centre("B"), centre("C"));
    let r: f64 = {
        let i = svg.find(" r=\"").unwrap() + 4;
        svg[i..].split('"').next().unwrap().parse().unwrap()
    };
    assert!(
        ((b.0 - c.0).powi(2) + (b.1 - c.1).powi(2)).sqrt() > 2.0 * r,
        "co-located tags overlap: {b:?} {c:?}"
    );
    // Start and end marked.
    assert!(svg.contains("data-info=\"start\"") && svg.contains("data-info=\"end\""));
    // The error colour runs from green to red at the requirement, and a
    // colour of its own past it.
    assert!(svg.contains("hsl(120,85%,42%)") && svg.contains(waymark::report::OVER_COLOUR));
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("target");
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(
        dir.join("map-preview.html"),
        format!("<!DOCTYPE html><html><body>{svg}</body></html>"),
    )
    .unwrap();
}
