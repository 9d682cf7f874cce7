//! The text summaries the commands print (one line each, for people and
//! for scripts that read them): the library formats them, the binary only
//! writes them where `--json` and `--quiet` say.

use super::plan::{counts_by_kind, PlanFiles, PlanOutcome};
use super::simulate::SimulateOutcome;

impl PlanOutcome {
    /// `waymark plan`'s summary: the plan, its validation, with `baseline`
    /// the uniform baseline's comparison, and the files written.
    pub fn summary(&self, baseline: bool) -> Vec<String> {
        let o = self;
        let mut lines = Vec::new();
        match &o.plan {
            PlanFiles::Route(f) => {
                let p = &f.plan;
                lines.push(format!("{}: {} new tag(s) ({}){} over {:.1} km, total cost {:.1}, max gap {:.0} m; requirement {} m with {} missed read(s) tolerated; predicted max 95 % bound {:.2} m (all read); lower bound {} new tag(s){}; method: {}",
                p.scenario,
                f.tag_count,
                counts_by_kind(&f.tags_by_mounting),
                if f.existing_tags_kept > 0 {
                    format!(" + {} installed", f.existing_tags_kept)
                } else {
                    String::new()
                },
                p.route_length_m / 1000.0,
                p.total_cost,
                p.max_gap_m,
                p.requirement_m,
                p.tolerate_missed_reads,
                p.predicted_max_bound95_m,
                p.lower_bound,
                if p.optimal { " (plan proven minimal)" } else { "" },
                p.method
            ));
                if let Some(v) = &p.validation {
                    lines.push(format!("validation: {} run(s), seed {}: {:.2} % of distance within {} m; {}; {} run(s) with a maximum above it; max horizontal error {:.2} m (run {}, t = {:.0} s, {:.0} m along the route)",
                    v.runs,
                    v.seed,
                    100.0 * v.fraction_within_requirement,
                    p.requirement_m,
                    v.rule,
                    v.runs_exceeding_requirement,
                    v.max_horizontal_error_m,
                    v.worst_run,
                    v.worst_t_s,
                    v.worst_distance_m
                ));
                }
                if baseline {
                    match &p.uniform_baseline {
                    Some(b) => lines.push(format!("uniform baseline (same standard: covariance check with {} missed read(s) tolerated, then Monte Carlo): {} tag(s) every {:.0} m keep {:.2} % of distance within {} m ({} run(s)); plan uses {}{}",
                        b.tolerate_missed_reads,
                        b.tag_count,
                        b.spacing_m,
                        100.0 * b.validation.fraction_within_requirement,
                        p.requirement_m,
                        b.validation.runs,
                        f.tag_count,
                        if b.tag_count > 0 {
                            format!(
                                " ({:+.0} %)",
                                100.0 * (f.tag_count as f64 - b.tag_count as f64)
                                    / b.tag_count as f64
                            )
                        } else {
                            String::new()
                        }
                    )),
                    None => lines.push(
                        "uniform baseline: none passes, even at the candidate spacing".to_string(),
                    ),
                }
                }
            }
            PlanFiles::Network(f) => {
                lines.extend(f.summary());
            }
        }
        lines.push(format!(
            "wrote {}/{} in {:.1} s",
            o.out.display(),
            o.files[..o.files.len().min(6)].join(", "),
            o.elapsed_s
        ));
        lines
    }
}

impl SimulateOutcome {
    /// `waymark simulate`'s summary: errors, filter consistency, tag reads,
    /// odometer faults, the odometer's calibration, the map feed, the
    /// requirement, and the files written.
    pub fn summary(&self) -> Vec<String> {
        let o = self;
        let mut lines = Vec::new();
        let result = &o.result;
        let s = &result.summary;
        lines.push(format!("{}: {} over {:.0} s, {:.1} km, {} run(s), seed {}: horizontal error max {:.2} m, rms {:.2} m, p95 {:.2} m; final E/N/U {:.2}/{:.2}/{:.2} m",
        s.name,
        s.mode,
        s.duration_s,
        s.distance_m / 1000.0,
        s.runs,
        s.seed,
        s.max_horizontal_error_m,
        s.rms_horizontal_error_m,
        s.p95_horizontal_error_m,
        s.final_error_enu_m[0],
        s.final_error_enu_m[1],
        s.final_error_enu_m[2],
    ));
        if let Some(n) = &s.nees {
            lines.push(format!("filter consistency: run-averaged horizontal NEES {:.2} (95 % band {:.2}..{:.2} for {} run(s)), inside the band {:.0} % of the time, above {:.0} %",
            n.mean,
            n.band_95[0],
            n.band_95[1],
            n.runs,
            100.0 * n.fraction_within_band,
            100.0 * n.fraction_above_band
        ));
        }
        let passes = result.runs.first().map_or(&[][..], |r| &r.tag_passes[..]);
        if let Some(t) = &s.tags {
            lines.push(format!("tag reads: {} accepted, {} rejected by the gate (all runs); run 0 passed {} tag(s), read {}",
            t.accepted,
            t.rejected,
            passes.len(),
            passes.iter().filter(|p| p.read).count()
        ));
            for e in &t.rejected_run0 {
                lines.push(format!(
                    "  run 0: tag {} read at {:.1} s rejected (NIS {:.1})",
                    e.tag_id, e.t_s, e.nis
                ));
            }
        }
        for f in &s.odometer_faults {
            lines.push(format!(
                "odometer failed from {:.0} s ({:.2} km) to the end",
                f.from_s,
                f.from_m / 1000.0
            ));
        }
        if let Some(c) = &s.odometer_calibration {
            let pair = |st: &crate::sim::metrics::CalibrationState, deg: bool| {
                if deg {
                    format!("{:.4}° / {:.4}°", st.rms_error, st.rms_sigma)
                } else {
                    format!("{:.2e} / {:.2e}", st.rms_error, st.rms_sigma)
                }
            };
            lines.push(format!(
                "odometer calibration at the end, RMS error / RMS filter σ over {} run(s): scale factor {}, pitch misalignment {}, yaw misalignment {} (run 0 over the run: calibration.csv)",
                s.runs,
                pair(&c.scale_factor, false),
                pair(&c.pitch_misalignment_deg, true),
                pair(&c.yaw_misalignment_deg, true),
            ));
        }
        if let Some(f) = result.runs.first().and_then(|r| r.map_feed) {
            lines.push(format!("map matching (run 0): {} fixes fed, {} accepted by the gate, {} at road ends, {} positions unmatched",
            f.fed, f.accepted, f.road_end, f.unmatched
        ));
        }
        if let (Some(r), Some(n)) = (s.requirement_m, s.runs_exceeding_requirement) {
            lines.push(format!(
                "requirement {r} m: {n} of {} run(s) exceed it; within it {:.1} % of the time",
                s.runs,
                100.0 * s.fraction_within_requirement.unwrap_or(0.0)
            ));
        }
        if let Some(rule) = o.requirement_rule.as_ref().and_then(|r| r["rule"].as_str()) {
            lines.push(format!("rule: {rule}"));
        }
        lines.push(format!(
            "wrote {} and {} in {:.2} s",
            o.out.join("errors.csv").display(),
            o.out.join("summary.json").display(),
            o.elapsed_s
        ));
        lines
    }
}
