//! The report's baseline sections for area plans (`plan --baseline`): the
//! validation beside the same drives without the new tags, and the
//! over-budget stretches driven both ways. Absent without `--baseline`.

use super::verdict::{badge, num, Level};
use quick_xml::escape::escape;
use std::fmt::Write;

/// The rule's outcome on `v`'s thinned samples as a badge: passed
/// (green), the observed share reaching the confidence but not its lower
/// bound (amber), or failed (red).
fn rule_badge(v: &serde_json::Value, confidence: Option<f64>) -> Option<String> {
    let (n, within) = (
        v["thinned_samples"].as_u64()?,
        v["thinned_within"].as_u64()?,
    );
    Some(if v["passed"].as_bool()? {
        badge(Level::Green, "passed")
    } else if n > 0 && confidence.is_some_and(|c| within as f64 / n as f64 >= c) {
        badge(Level::Amber, "not shown (too few samples)")
    } else {
        badge(Level::Red, "FAILED")
    })
}

/// A table of figures side by side: with the plan and without the new
/// tags. A row shows only when both of its figures exist.
fn compare_table(rows: &[(String, Option<String>, Option<String>)]) -> String {
    let mut html = String::from(
        "<table class=\"kv compare\"><thead><tr><th></th><th>with the plan</th><th>without the new tags</th></tr></thead><tbody>",
    );
    for (k, a, b) in rows {
        if let (Some(a), Some(b)) = (a, b) {
            let _ = write!(
                html,
                "<tr><th>{}</th><td>{a}</td><td>{b}</td></tr>",
                escape(k)
            );
        }
    }
    html.push_str("</tbody></table>");
    html
}

/// `waymark plan --baseline` on an area plan: the validation with the plan
/// beside the same chains, runs and seeds driven without the new tags
/// (`validation.without_new_tags`), and the stretches where the plan's
/// budget without tags passes 1 driven both ways
/// (`validation.over_budget_stretches`). `None` when the plan has neither
/// (no `--baseline`).
pub(super) fn baseline(p: &serde_json::Value) -> Option<String> {
    let v = &p["validation"];
    let (b, st) = (&v["without_new_tags"], &v["over_budget_stretches"]);
    if !b.is_object() && !st.is_object() {
        return None;
    }
    let req = num(&p["requirement_m"])?;
    let conf = num(&v["requirement_confidence"]);
    let esc = |s: String| escape(s.as_str()).into_owned();
    let samples = |v: &serde_json::Value| {
        Some(esc(format!(
            "{} of {} (lower 95 % bound {:.4})",
            v["thinned_within"].as_u64()?,
            v["thinned_samples"].as_u64()?,
            num(&v["share_lower_95"])?
        )))
    };
    let metres = |x: &serde_json::Value| num(x).map(|m| format!("{m:.2} m"));
    let mut html = String::new();
    if b.is_object() {
        let runs = v["runs"].as_u64();
        let exceeding =
            |x: &serde_json::Value| Some(format!("{} of {}", x["runs_exceeding"].as_u64()?, runs?));
        let over = |x: &serde_json::Value| {
            Some(format!(
                "{} of {} within; max error {:.2} m",
                x["over_budget_within"].as_u64()?,
                v["over_budget_samples"].as_u64()?,
                num(&x["over_budget_max_error_m"])?
            ))
        };
        let wrong = |x: &serde_json::Value| {
            num(&x["map_matching_wrong_road_share"]).map(|w| format!("{:.2} %", 100.0 * w))
        };
        let kept = b["tags"].as_u64().unwrap_or(0);
        let _ = write!(
            html,
            "<h3 id=\"baseline\">What the new tags buy</h3><p class=\"figures\">The validation's chains, runs and seeds driven again {} (<code>waymark plan --baseline</code>), judged by the same rule.</p>",
            if kept > 0 {
                format!("with only the {kept} installed tag(s)")
            } else {
                "without any tag".into()
            }
        );
        html.push_str(&compare_table(&[
            (
                format!("time within {req} m"),
                num(&v["fraction_within_requirement"]).map(|f| format!("{:.2} %", 100.0 * f)),
                num(&b["fraction_within_requirement"]).map(|f| format!("{:.2} %", 100.0 * f)),
            ),
            (
                format!("thinned samples within {req} m"),
                samples(v),
                samples(b),
            ),
            ("rule".into(), rule_badge(v, conf), rule_badge(b, conf)),
            (
                "max horizontal error".into(),
                metres(&v["max_horizontal_error_m"]),
                metres(&b["max_horizontal_error_m"]),
            ),
            (
                "median of the per-run maxima".into(),
                metres(&v["median_run_max_m"]),
                metres(&b["median_run_max_m"]),
            ),
            (
                "runs exceeding the requirement".into(),
                exceeding(v),
                exceeding(b),
            ),
            (
                "samples where the plan's budget without tags passes 1".into(),
                over(v),
                over(b),
            ),
            ("map matching on the wrong road".into(), wrong(v), wrong(b)),
        ]));
        if let Some(u) = num(&v["max_budget_without_tags"]) {
            let _ = write!(
                html,
                "<p class=\"figures\">Largest budget without tags on these drives: {u:.2} (1: the plan's predicted bound reaches the requirement).</p>"
            );
        }
    }
    if st.is_object() {
        let intro = (|| {
            Some(format!(
                "The {} stretch(es) where the plan's budget without tags peaks highest ({:.2}–{:.2}) on {} fresh chain(s), each driven {} time(s) from {:.0} m before its resetting turn with the same seeds both ways; samples over budget only.",
                st["stretches"].as_u64()?,
                num(&st["peak_budget_min"])?,
                num(&st["peak_budget_max"])?,
                st["searched_chains"].as_u64()?,
                st["runs_per_stretch"].as_u64()?,
                num(&st["lead_in_m"])?,
            ))
        })()
        .unwrap_or_else(|| "The stretches where the plan's budget without tags passes 1, driven with and without the new tags; samples over budget only.".into());
        stretch_table(
            &mut html,
            st,
            req,
            conf,
            ("over-budget-stretches", "Over-budget stretches"),
            &intro,
        );
    }
    let cr = &v["credited_stretches"];
    if cr.is_object() {
        let intro = (|| {
            Some(format!(
                "The {} stretch(es) that the calibrated reach credits: over budget at the single reach ({:.2}–{:.2}), within it at the plan's two levels, on {} fresh chain(s); each driven {} time(s) from its chain's start (up to {:.1} km before it), with the same seeds both ways; samples from where the single reach's budget passes 1.",
                cr["stretches"].as_u64()?,
                num(&cr["peak_budget_min"])?,
                num(&cr["peak_budget_max"])?,
                cr["searched_chains"].as_u64()?,
                cr["runs_per_stretch"].as_u64()?,
                num(&cr["lead_in_m"])? / 1000.0,
            ))
        })()
        .unwrap_or_else(|| "The stretches that the calibrated reach credits, driven from their chains' starts with and without the new tags.".into());
        stretch_table(
            &mut html,
            cr,
            req,
            conf,
            ("credited-stretches", "Stretches credited by calibration"),
            &intro,
        );
    }
    Some(html)
}

/// One stretch test of `plan --baseline` (`validation.over_budget_stretches`
/// or `credited_stretches`): a heading `(id, title)`, its `intro` and the
/// figures with and without the new tags.
fn stretch_table(
    html: &mut String,
    st: &serde_json::Value,
    req: f64,
    conf: Option<f64>,
    (id, title): (&str, &str),
    intro: &str,
) {
    let esc = |s: &str| escape(s).into_owned();
    let samples = |v: &serde_json::Value| {
        Some(esc(&format!(
            "{} of {} (lower 95 % bound {:.4})",
            v["thinned_within"].as_u64()?,
            v["thinned_samples"].as_u64()?,
            num(&v["share_lower_95"])?
        )))
    };
    let metres = |x: &serde_json::Value| num(x).map(|m| format!("{m:.2} m"));
    let (w, wo) = (&st["with_tags"], &st["without_new_tags"]);
    let runs = st["stretches"]
        .as_u64()
        .zip(st["runs_per_stretch"].as_u64())
        .map(|(a, b)| a * b);
    let exceeding =
        |x: &serde_json::Value| Some(format!("{} of {}", x["runs_exceeding"].as_u64()?, runs?));
    let _ = write!(
        html,
        "<h3 id=\"{id}\">{title}</h3><p class=\"figures\">{}</p>",
        esc(intro)
    );
    html.push_str(&compare_table(&[
        (format!("samples within {req} m"), samples(w), samples(wo)),
        ("rule".into(), rule_badge(w, conf), rule_badge(wo, conf)),
        (
            "max horizontal error".into(),
            metres(&w["max_horizontal_error_m"]),
            metres(&wo["max_horizontal_error_m"]),
        ),
        (
            "runs exceeding the requirement".into(),
            exceeding(w),
            exceeding(wo),
        ),
    ]));
}
