//! The report's sections as HTML: verdicts with their rule, filter
//! consistency, the plan tables (route and area), the tag table and the
//! notes on what the folder lacks. Every number shown exists in the files;
//! a row whose number does not exist is left out rather than shown as a
//! dash or NaN.

use super::folder::{TagRow, TagSource};
use super::verdict::{
    badge, figures_text, level, num, rule_text, share_text, upper_bound, Evidence, Level, Share,
    CONFIDENCE,
};
use quick_xml::escape::escape;
use std::fmt::Write;

/// The rule's thinned samples as a file records them (`thinned_samples`,
/// `thinned_within`, `requirement_confidence`), when it does.
fn share_of(v: &serde_json::Value) -> Option<Share> {
    Some(Share {
        samples: v["thinned_samples"].as_u64()?,
        within: v["thinned_within"].as_u64()?,
        confidence: num(&v["requirement_confidence"])?,
    })
}

/// The headline of a verdict: `what` (e.g. "Simulation") and the share's
/// figures.
fn headline(l: Level, what: &str, e: &Evidence) -> String {
    let r = e.requirement_m;
    match (l, e.share) {
        (Level::Green, Some(s)) => format!(
            "{what} meets the {r} m requirement with probability at least {} (95 % confidence)",
            s.confidence
        ),
        (Level::Amber, Some(s)) if s.samples > 0 => format!(
            "{what} keeps {:.2} % of the samples within {r} m, but that is not enough to be sure of {} (95 % confidence): run more",
            100.0 * s.observed(),
            s.confidence
        ),
        (Level::Red, Some(s)) => format!(
            "{what} does not meet the {r} m requirement: {:.2} % of the samples within it, below {}",
            100.0 * s.observed(),
            s.confidence
        ),
        _ => format!("{what}: the rule cannot be applied to the {r} m requirement (figures missing)"),
    }
}

/// The verdict of a simulation, under the stated rule (`summary.json`'s
/// `requirement_rule`, written by `waymark simulate`).
pub fn sim_verdict(s: &serde_json::Value) -> String {
    let (Some(r), Some(share)) = (
        num(&s["requirement_m"]),
        num(&s["fraction_within_requirement"]),
    ) else {
        return format!(
            "<p>{}</p>",
            badge(
                Level::Info,
                "No requirement set in the scenario: nothing to judge against"
            )
        );
    };
    let runs = s["runs"].as_u64().unwrap_or(1);
    // The median run's maximum, as the summary and the plots pick it.
    let median_run = super::folder::example_runs(&super::folder::per_run_max(s)).map(|(m, _)| m.1);
    let e = Evidence {
        requirement_m: r,
        runs,
        runs_exceeding: s["runs_exceeding_requirement"].as_u64(),
        max_error_m: num(&s["max_horizontal_error_m"]).unwrap_or(0.0),
        median_run_max_m: median_run.filter(|_| runs > 1),
        share_within: share,
        share: share_of(&s["requirement_rule"]),
    };
    let l = level(&e);
    let first = num(&s["time_to_exceed_requirement_s"])
        .map(|t| format!(" First exceeded at {t:.0} s (earliest over the runs)."))
        .unwrap_or_default();
    format!(
        "<p>{}</p><p class=\"figures\">Simulation, {runs} run(s): {} {}{first}</p>",
        badge(l, &headline(l, "Simulation", &e)),
        escape(share_text(&e)),
        escape(figures_text(&e, "time")),
    )
}

/// The verdict of a plan: its Monte Carlo validation under the stated rule,
/// or, without one, its prediction (amber at best: not simulated).
pub fn plan_verdict(p: &serde_json::Value) -> String {
    let r = num(&p["requirement_m"]).unwrap_or(0.0);
    let n = p["tag_count"].as_u64().unwrap_or(0);
    let network = p["coverage"].as_str() == Some("network");
    let v = &p["validation"];
    let predicted = num(&p["predicted_max_bound95_m"]);
    let predicted_text = match (predicted, network) {
        (Some(b), _) => format!(
            " Predicted max 95 % bound {b:.2} m with all tags read{}.",
            num(&p["predicted_max_bound95_missed_m"])
                .map(|m| format!(
                    ", {m:.2} m with any {} consecutive tag(s) missed",
                    p["tolerate_missed_reads"].as_u64().unwrap_or(0)
                ))
                .unwrap_or_default()
        ),
        (None, true) if p["guarantee"]["statement"].is_string() => format!(
            " Planned for traffic (chains of trips): {}.",
            p["guarantee"]["statement"].as_str().unwrap_or_default()
        ),
        (None, true) => {
            let verified = p["verified"].as_bool() == Some(true);
            format!(
                " Every directed road's predicted bound within {r} m with up to {} missed read(s) {}.",
                p["tolerate_missed_reads"].as_u64().unwrap_or(0),
                if verified {
                    "(verified over all walks)"
                } else {
                    "(not verified over all walks)"
                }
            )
        }
        _ => String::new(),
    };
    match (
        num(&v["fraction_within_requirement"]),
        v["runs"].as_u64(),
        num(&v["max_horizontal_error_m"]),
    ) {
        (Some(share), Some(runs), Some(max)) => {
            let e = Evidence {
                requirement_m: r,
                runs,
                // Route plans: runs_exceeding_requirement; area plans: runs_exceeding.
                runs_exceeding: v["runs_exceeding_requirement"]
                    .as_u64()
                    .or(v["runs_exceeding"].as_u64()),
                max_error_m: max,
                median_run_max_m: num(&v["median_run_max_m"]),
                share_within: share,
                share: share_of(v),
            };
            let l = level(&e);
            let head = headline(l, &format!("Plan of {n} new tag(s)"), &e);
            let paths = v["paths"]
                .as_u64()
                .map(|k| format!(" on {k} sampled chain(s) of trips"))
                .unwrap_or_default();
            format!(
                "<p>{}</p><p class=\"figures\">Validation by {runs} Monte Carlo run(s){paths}, seed {}: {} {}{}</p>",
                badge(l, &head),
                v["seed"].as_u64().unwrap_or(0),
                escape(share_text(&e)),
                escape(figures_text(&e, "distance")),
                escape(&predicted_text),
            )
        }
        _ => {
            let within = predicted.is_none_or(|b| b <= r);
            let (l, head) = if within {
                (
                    Level::Amber,
                    format!("Plan of {n} new tag(s) predicted within {r} m, not validated by simulation"),
                )
            } else {
                (
                    Level::Red,
                    format!("Plan of {n} new tag(s) predicted to exceed {r} m, not validated by simulation"),
                )
            };
            format!(
                "<p>{}</p><p class=\"figures\">{}</p><p class=\"rule\">Rule: a plan is green only when a Monte Carlo validation shows the requirement held with its confidence; a prediction alone is amber at best (run waymark plan with --runs N).</p>",
                badge(l, &head),
                escape(predicted_text.trim())
            )
        }
    }
}

/// The rule the verdicts follow, once for the page, with the confidence
/// `p` the verdicts used (from the files; the default 0.95 when none
/// records it).
pub fn rule(confidence: Option<f64>) -> String {
    format!(
        "<p class=\"rule\">{}</p>",
        escape(rule_text(confidence.unwrap_or(0.95)))
    )
}

/// The confidence `p` a plan's validation or a simulation's rule used.
pub fn confidence(plan: &serde_json::Value, summary: &serde_json::Value) -> Option<f64> {
    num(&plan["validation"]["requirement_confidence"])
        .or(num(&summary["requirement_rule"]["requirement_confidence"]))
}

/// Filter consistency: the run-averaged NEES against its band, and what it means.
pub fn nees(s: &serde_json::Value) -> Option<String> {
    let n = &s["nees"];
    let (mean, lo, hi) = (
        num(&n["mean"])?,
        num(&n["band_95"][0])?,
        num(&n["band_95"][1])?,
    );
    let runs = n["runs"].as_u64().unwrap_or(0);
    let dof = n["dof"].as_u64().unwrap_or(2);
    let inside = num(&n["fraction_within_band"]).unwrap_or(0.0);
    let above = num(&n["fraction_above_band"]).unwrap_or(0.0);
    let (l, meaning) = if mean < lo {
        (
            Level::Amber,
            "Below the band: the filter is pessimistic — its covariance is larger than the errors it makes, so its 95 % bound (and the planner's prediction, from the same filter) overstates the error: safe, but tags may be more than needed",
        )
    } else if mean > hi {
        (
            Level::Red,
            "Above the band: the filter is optimistic — its errors are larger than its covariance says, so its 95 % bound understates the error and cannot be trusted",
        )
    } else {
        (
            Level::Green,
            "Inside the band: the filter's covariance matches the errors it makes, so its 95 % bound can be trusted",
        )
    };
    Some(format!(
        "<p>{} <span class=\"figures\">Run-averaged horizontal NEES {mean:.2} ({dof} degrees of freedom, 95 % band {lo:.2}–{hi:.2} for {runs} run(s)); inside the band {:.0} % of the time, above it {:.0} %. {}.</span></p>",
        badge(l, &format!("Filter consistency: NEES {mean:.2}")),
        100.0 * inside,
        100.0 * above,
        meaning
    ))
}

/// What the filter learnt of the odometer's calibration by the end
/// (`summary.json`'s `odometer_calibration`): run 0's estimates with their
/// σ beside the simulated values, and over the runs the final errors' RMS
/// against the filter's RMS σ. `None` without it (no filter, or no odometer
/// aiding).
pub fn calibration(s: &serde_json::Value) -> Option<String> {
    let c = &s["odometer_calibration"];
    let states = [
        ("yaw_misalignment_deg", "yaw misalignment", true),
        ("pitch_misalignment_deg", "pitch misalignment", true),
        ("scale_factor", "scale factor", false),
    ];
    let fmt = |x: f64, deg: bool| {
        if deg {
            format!("{x:.3}°")
        } else {
            format!("{x:.2e}")
        }
    };
    let mut run0 = Vec::new();
    let (mut errors, mut sigmas) = (Vec::new(), Vec::new());
    for (key, name, deg) in states {
        let v = &c[key];
        let f = |k: &str| num(&v[k]);
        run0.push(format!(
            "{name} {} ± {} (simulated {})",
            fmt(f("estimate_run0")?, deg),
            fmt(f("sigma_run0")?, deg),
            fmt(f("truth_run0")?, deg)
        ));
        errors.push(fmt(f("rms_error")?, deg));
        sigmas.push(fmt(f("rms_sigma")?, deg));
    }
    let runs = s["runs"].as_u64().unwrap_or(1);
    Some(format!(
        "<p>Odometer calibration at the end (run 0, estimate ± filter σ): {}. <span class=\"figures\">Over {runs} run(s) the final errors' RMS is {} against the filter's RMS σ {}.</span></p>",
        escape(run0.join(", ")),
        errors.join(", "),
        sigmas.join(", ")
    ))
}

fn table(rows: &[(&str, String)]) -> String {
    let mut html = String::from("<table class=\"kv\">");
    for (k, v) in rows {
        let _ = write!(html, "<tr><th>{k}</th><td>{}</td></tr>", escape(v));
    }
    html.push_str("</table>");
    html
}

fn by_mounting(p: &serde_json::Value) -> String {
    p["tags_by_mounting"]
        .as_object()
        .map(|m| {
            m.iter()
                .map(|(k, v)| format!("{} {}", v.as_u64().unwrap_or(0), k.replace('_', " ")))
                .collect::<Vec<_>>()
                .join(", ")
        })
        .filter(|s| !s.is_empty())
        .unwrap_or_else(|| "none".into())
}

/// Pushes `(key, value)` when the value exists.
fn push(rows: &mut Vec<(&'static str, String)>, k: &'static str, v: Option<String>) {
    if let Some(v) = v {
        rows.push((k, v));
    }
}

/// The route plan's table.
pub fn plan_table(p: &serde_json::Value, missed_note: Option<String>) -> String {
    let mut rows: Vec<(&str, String)> = Vec::new();
    rows.push((
        "new tags",
        format!(
            "{} ({})",
            p["tag_count"].as_u64().unwrap_or(0),
            by_mounting(p)
        ),
    ));
    push(
        &mut rows,
        "installed tags kept",
        p["existing_tags_kept"]
            .as_u64()
            .filter(|k| *k > 0)
            .map(|k| k.to_string()),
    );
    push(
        &mut rows,
        "lower bound on new tags",
        p["lower_bound"].as_u64().map(|b| {
            format!(
                "{b}{}",
                if p["optimal"].as_bool() == Some(true) {
                    " (the plan is minimal)"
                } else {
                    ""
                }
            )
        }),
    );
    push(
        &mut rows,
        "total cost",
        num(&p["total_cost"]).map(|c| format!("{c:.1}")),
    );
    push(
        &mut rows,
        "route length",
        num(&p["route_length_m"]).map(|d| format!("{:.2} km", d / 1e3)),
    );
    push(
        &mut rows,
        "largest gap between tags",
        num(&p["max_gap_m"]).map(|g| format!("{g:.0} m")),
    );
    push(
        &mut rows,
        "reach from the start without tags",
        num(&p["start_reach_m"]).map(|g| format!("{g:.0} m")),
    );
    push(
        &mut rows,
        "requirement",
        num(&p["requirement_m"]).map(|r| format!("{r} m")),
    );
    push(
        &mut rows,
        "missed reads tolerated",
        p["tolerate_missed_reads"].as_u64().map(|k| k.to_string()),
    );
    push(
        &mut rows,
        "predicted max 95 % bound, all tags read",
        num(&p["predicted_max_bound95_m"]).map(|b| format!("{b:.2} m")),
    );
    push(
        &mut rows,
        "predicted max 95 % bound, tags missed",
        missed_note,
    );
    validation_rows(&mut rows, &p["validation"], num(&p["requirement_m"]));
    let b = &p["uniform_baseline"];
    if b.is_object() {
        push(
            &mut rows,
            "uniform baseline",
            (|| {
                Some(format!(
                    "{} tag(s) every {:.0} m: {:.2} % of the distance within the requirement",
                    b["tag_count"].as_u64()?,
                    num(&b["spacing_m"])?,
                    100.0 * num(&b["validation"]["fraction_within_requirement"])?
                ))
            })(),
        );
    }
    push(&mut rows, "method", p["method"].as_str().map(String::from));
    table(&rows)
}

fn validation_rows(
    rows: &mut Vec<(&'static str, String)>,
    v: &serde_json::Value,
    requirement_m: Option<f64>,
) {
    if !v.is_object() {
        rows.push((
            "validation",
            "not run (waymark plan --runs N runs it)".into(),
        ));
        return;
    }
    push(
        rows,
        "validation",
        (|| {
            Some(format!(
                "{} run(s), seed {}: {:.2} % of the distance within the requirement; max horizontal error {:.2} m (run {}, {:.0} m along{})",
                v["runs"].as_u64()?,
                v["seed"].as_u64()?,
                100.0 * num(&v["fraction_within_requirement"])?,
                num(&v["max_horizontal_error_m"])?,
                v["worst_run"].as_u64()?,
                num(&v["worst_distance_m"])?,
                v["worst_path"]
                    .as_u64()
                    .map(|k| format!(" sampled path {k}"))
                    .unwrap_or_default(),
            ))
        })(),
    );
    // Counted by the validation, or known to be none when the largest
    // error is within the requirement.
    let none = num(&v["max_horizontal_error_m"])
        .zip(requirement_m)
        .is_some_and(|(m, r)| m <= r)
        .then_some(0);
    push(
        rows,
        "runs exceeding the requirement",
        v["runs_exceeding_requirement"]
            .as_u64()
            .or(v["runs_exceeding"].as_u64())
            .or(none)
            .map(|k| {
                let n = v["runs"].as_u64().unwrap_or(0);
                format!(
                    "{k} of {n} (chance per run ≤ {:.1} % at {:.0} % confidence)",
                    100.0 * upper_bound(k, n, CONFIDENCE),
                    100.0 * CONFIDENCE
                )
            }),
    );
    push(
        rows,
        "median of the per-run maxima",
        num(&v["median_run_max_m"]).map(|m| format!("{m:.2} m")),
    );
    push(
        rows,
        "validation rule",
        v["rule"].as_str().map(String::from),
    );
    // any_walk plans: the walk DP's worst walks driven with their tags missed.
    let d = &v["design_walks"];
    push(
        rows,
        "worst walks (tags on them missed)",
        (|| {
            Some(format!(
                "{} walk(s) × {} run(s): max horizontal error {:.2} m (walk {}); {} run(s) above the requirement; {}",
                d["walks"].as_u64()?,
                d["runs_per_walk"].as_u64()?,
                num(&d["max_horizontal_error_m"])?,
                d["worst_walk"].as_u64()?,
                d["runs_exceeding"].as_u64()?,
                d["rule"].as_str()?
            ))
        })(),
    );
}

/// The area plan's table: tags, lower bound, reach, coverage, validation,
/// and the reasons tags are needed.
pub fn network_table(
    p: &serde_json::Value,
    bounds: &[(f64, Option<f64>)],
    reasons: &[String],
    tags: &[TagRow],
) -> String {
    let mut rows: Vec<(&str, String)> = Vec::new();
    rows.push((
        "new tags",
        format!(
            "{} ({})",
            p["tag_count"].as_u64().unwrap_or(0),
            by_mounting(p)
        ),
    ));
    push(
        &mut rows,
        "installed tags kept",
        p["existing_kept"]
            .as_u64()
            .filter(|k| *k > 0)
            .map(|k| k.to_string()),
    );
    push(
        &mut rows,
        "lower bound on new tags",
        p["lower_bound"].as_u64().map(|b| {
            format!(
                "{b}{}",
                num(&p["lower_bound_cost"])
                    .map(|c| format!(" (cost {c:.1})"))
                    .unwrap_or_default()
            )
        }),
    );
    push(
        &mut rows,
        "total cost",
        num(&p["total_cost"]).map(|c| format!("{c:.1}")),
    );
    push(
        &mut rows,
        "roads covered",
        (|| {
            Some(format!(
                "{} directed road(s), {:.2} km",
                p["directed_edges"].as_u64()?,
                num(&p["directed_length_km"])?
            ))
        })(),
    );
    push(
        &mut rows,
        "reach between fixes",
        (|| {
            // Two levels: the calibrated reaches of plan.json's
            // matched_reach, slowest and fastest class.
            let calibrated = p["matched_reach"].as_array().and_then(|a| {
                let v: Vec<f64> = a
                    .iter()
                    .filter_map(|c| num(&c["calibrated_reach_m"]))
                    .collect();
                let lo = v.iter().copied().reduce(f64::min)?;
                Some((lo, v.iter().copied().fold(lo, f64::max)))
            });
            let levels = match (p["reach_levels"].as_u64(), calibrated) {
                (Some(2), Some((lo, hi))) => format!(
                    "; two levels: each chain at this reach until calibrated ({} right-angle turns \
                     and {:.0} km driven), then at {lo:.0}–{hi:.0} m",
                    crate::planner::network::CALIBRATION_TURNS,
                    crate::planner::network::CALIBRATION_M / 1000.0
                ),
                _ => String::new(),
            };
            Some(format!(
                "{:.0} m (slowest speed class; fastest {:.0} m); steady state {:.0} m, from the start {:.0} m{levels}",
                num(&p["reach_m"])?,
                num(&p["budget_reference_m"])?,
                num(&p["steady_reach_m"])?,
                num(&p["start_reach_m"])?
            ))
        })(),
    );
    push(
        &mut rows,
        "requirement",
        num(&p["requirement_m"]).map(|r| format!("{r} m")),
    );
    push(
        &mut rows,
        "missed reads tolerated",
        p["tolerate_missed_reads"].as_u64().map(|k| k.to_string()),
    );
    let g = &p["guarantee"];
    if g.is_object() {
        // Traffic plans: a statistical certification on fresh chains of
        // trips, not a check of every walk.
        push(
            &mut rows,
            "certification",
            g["statement"].as_str().map(|st| {
                format!(
                    "{} {st}; the worst certification chain uses {:.0} % of the error budget",
                    if g["holds"].as_bool() == Some(true) {
                        "holds:"
                    } else {
                        "DOES NOT HOLD:"
                    },
                    100.0 * num(&g["worst_chain_budget"]).unwrap_or(0.0)
                )
            }),
        );
    } else {
        push(
            &mut rows,
            "walk check",
            p["verified"].as_bool().map(|v| {
                format!(
                    "{}; the longest walk with at most k passes uses {:.0} % of the budget",
                    if v {
                        "verified: no walk exceeds the budget"
                    } else {
                        "not verified"
                    },
                    100.0 * num(&p["longest_walk_budget"]).unwrap_or(0.0)
                )
            }),
        );
    }
    if !bounds.is_empty() {
        let max = bounds.iter().map(|b| b.0).fold(0.0, f64::max);
        let r = num(&p["requirement_m"]).unwrap_or(f64::INFINITY);
        let over = bounds.iter().filter(|b| b.0 > r).count();
        rows.push((
            "predicted 95 % bound on the roads",
            format!(
                "largest {max:.2} m over {} road piece(s); {over} piece(s) above the requirement",
                bounds.len()
            ),
        ));
        let without: Vec<f64> = bounds.iter().filter_map(|b| b.1).collect();
        if !without.is_empty() {
            rows.push((
                "predicted 95 % bound without tags",
                format!(
                    "largest {:.0} m",
                    without.iter().copied().fold(0.0, f64::max)
                ),
            ));
        }
    }
    validation_rows(&mut rows, &p["validation"], num(&p["requirement_m"]));
    push(
        &mut rows,
        "worst point of the validation",
        (|| {
            let v = &p["validation"];
            Some(format!(
                "{:.6}, {:.6}{}",
                num(&v["worst_lat"])?,
                num(&v["worst_lon"])?,
                v["worst_road_id"]
                    .as_str()
                    .map(|r| format!(" on road {r}"))
                    .unwrap_or_default()
            ))
        })(),
    );
    push(&mut rows, "method", p["method"].as_str().map(String::from));
    let mut html = table(&rows);
    if let Some(b) = super::baseline::baseline(p) {
        html.push_str(&b);
    }
    // Why tags are needed: the tags' reasons, and the road pieces' (from
    // coverage.geojson), each grouped by their wording with the figures
    // left out and counted.
    let tag_reasons = group_reasons(tags.iter().map(|t| t.reason.as_str()));
    if !tag_reasons.is_empty() {
        let n = tags.iter().filter(|t| !t.reason.is_empty()).count();
        let _ = write!(
            html,
            "<h3>Why tags are needed</h3><p class=\"figures\">{n} tag(s) by the plan's reason (figures such as lengths and speeds replaced by …; one example of each; every tag's own reason is in the tag table).</p>{}",
            reasons_table(&tag_reasons)
        );
    }
    let piece_reasons = group_reasons(reasons.iter().map(String::as_str));
    if !piece_reasons.is_empty() {
        let _ = write!(
            html,
            "<h3>Road pieces by reason</h3><p class=\"figures\">{} road piece(s) of <code>coverage.geojson</code>, by reason.</p>{}",
            reasons.iter().filter(|r| !r.is_empty()).count(),
            reasons_table(&piece_reasons)
        );
    }
    html
}

/// Reasons grouped by their wording with each number replaced by "…":
/// (the wording, count, one example), most frequent first.
fn group_reasons<'a>(reasons: impl Iterator<Item = &'a str>) -> Vec<(String, usize, &'a str)> {
    let mut groups: Vec<(String, usize, &'a str)> = Vec::new();
    for r in reasons.filter(|r| !r.is_empty()) {
        // Numbers out, except in arithmetic (the "k + 1" of a rule).
        let mut key = String::with_capacity(r.len());
        let mut number = String::new();
        let flush = |key: &mut String, number: &mut String| {
            if number.is_empty() {
                return;
            }
            let arithmetic = key.trim_end().ends_with(['+', '-']);
            key.push_str(if arithmetic { number.as_str() } else { "…" });
            number.clear();
        };
        for c in r.chars() {
            if c.is_ascii_digit() || (!number.is_empty() && c == '.') {
                number.push(c);
            } else {
                flush(&mut key, &mut number);
                key.push(c);
            }
        }
        flush(&mut key, &mut number);
        match groups.iter_mut().find(|g| g.0 == key) {
            Some(g) => g.1 += 1,
            None => groups.push((key, 1, r)),
        }
    }
    groups.sort_by(|a, b| b.1.cmp(&a.1).then_with(|| a.0.cmp(&b.0)));
    groups
}

fn reasons_table(groups: &[(String, usize, &str)]) -> String {
    let mut html = String::from("<table class=\"kv reasons\">");
    for (key, n, example) in groups {
        let _ = write!(html, "<tr><td>{n}</td><td>{}", escape(key.as_str()));
        if key != example {
            let _ = write!(
                html,
                "<br><span class=\"figures\">e.g. {}</span>",
                escape(*example)
            );
        }
        html.push_str("</td></tr>");
    }
    html.push_str("</table>");
    html
}

/// The tag table: one row per tag, in the installer file's order.
pub fn tag_table(tags: &[TagRow], source: &TagSource) -> String {
    let with_reason = tags.iter().any(|t| !t.reason.is_empty());
    let source = match source {
        TagSource::File(name) => format!("the lines of <code>{}</code>", escape(name)),
        TagSource::Plan => "the tags of <code>plan.json</code> (no payloads)".to_string(),
    };
    let mut html = format!(
        "<p>{} tag(s); the rows are {source}{}. Hover a tag on the map for its id.</p>\
         <div class=\"scroll\"><table class=\"tags\" id=\"tag-table\"><thead><tr><th>tag_id</th><th>lat</th><th>lon</th>\
         <th>height (m)</th><th>mounting</th><th>road</th><th>chainage (m)</th><th>side</th>{}<th>payload</th></tr></thead><tbody>",
        tags.len(),
        if tags.iter().any(|t| t.existing) {
            " and the installed tags kept"
        } else {
            ""
        },
        if with_reason { "<th>reason</th>" } else { "" }
    );
    let opt = |v: Option<f64>, d: usize| v.map(|x| format!("{x:.d$}")).unwrap_or_default();
    for t in tags {
        let _ = write!(
            html,
            "<tr{}><td>{}</td><td>{:.7}</td><td>{:.7}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td>",
            if t.existing { " class=\"existing\"" } else { "" },
            escape(&t.tag_id),
            t.lat_lon[0],
            t.lat_lon[1],
            opt(t.height_m, 2),
            escape(t.mounting.replace('_', " ")),
            escape(&t.road),
            opt(t.chainage_m, 1),
            escape(&t.side),
        );
        if with_reason {
            let _ = write!(html, "<td>{}</td>", escape(&t.reason));
        }
        let _ = write!(
            html,
            "<td><code>{}</code></td></tr>",
            escape(&t.payload_hex)
        );
    }
    html.push_str("</tbody></table></div>");
    html
}

/// What the folder lacks, as a list.
pub fn notes(notes: &[String]) -> Option<String> {
    if notes.is_empty() {
        return None;
    }
    let mut html =
        String::from("<section class=\"notes\" id=\"missing\"><h2>What this folder lacks</h2><ul>");
    for n in notes {
        let _ = write!(html, "<li>{}</li>", escape(n));
    }
    html.push_str("</ul></section>");
    Some(html)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reasons_are_grouped_by_wording_without_their_figures() {
        let g = group_reasons(
            [
                "tunnel; up to 1097 m driven without a tag (reach 1075 m at 10 km/h)",
                "tunnel; up to 4619 m driven without a tag (reach 875 m at 5 km/h)",
                "",
                "any walk passes k + 1 tags",
                "tunnel; 2.4 km without a tag",
            ]
            .into_iter(),
        );
        assert_eq!(g.len(), 3, "{g:?}");
        assert_eq!(
            g[0],
            (
                "tunnel; up to … m driven without a tag (reach … m at … km/h)".to_string(),
                2,
                "tunnel; up to 1097 m driven without a tag (reach 1075 m at 10 km/h)"
            )
        );
        assert!(g.iter().any(|x| x.0 == "any walk passes k + 1 tags"));
        assert!(g.iter().any(|x| x.0 == "tunnel; … km without a tag"));
        let html = reasons_table(&g);
        assert_eq!(html.matches("<tr>").count(), 3);
        assert!(html.contains("e.g. tunnel; up to 1097 m"));
    }
}
