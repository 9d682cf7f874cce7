//! Exact walk coverage by integer programming with lazy constraint
//! generation (pure-Rust `microlp` branch and bound).
//!
//! Minimise `Σ cost_s x_s` over binary `x` (installed sites fixed to 1)
//! subject to, for every walk `W` longer than `R`,
//! `Σ_s passes_W(s) x_s ≥ k + 1`. There are infinitely many walks, so the
//! programme starts with the witnesses of the installed-only selection; each
//! optimum is checked exactly by [`cover::check`]; the witnesses of
//! its violations become new constraints; repeat. Every constraint is valid
//! for every feasible selection, so each proven optimum is a lower bound, and
//! the first optimum that passes the check is optimal. Branch and bound is
//! limited by a node budget (deterministic, unlike a time limit); when the
//! budget or the round limit is hit the caller falls back to the greedy.

use super::cover::{self, CoverProblem, Walk};
use std::collections::HashSet;

/// Limits of the exact method.
#[derive(Debug, Clone, Copy)]
pub struct IlpLimits {
    /// Lazy-constraint rounds.
    pub max_rounds: usize,
    /// Branch-and-bound nodes per solve.
    pub node_limit: u64,
    /// Largest number of constraints kept.
    pub max_constraints: usize,
}

impl Default for IlpLimits {
    fn default() -> Self {
        Self {
            max_rounds: 60,
            node_limit: 50_000,
            max_constraints: 20_000,
        }
    }
}

/// The outcome of [`solve`].
#[derive(Debug, Clone, PartialEq)]
pub enum IlpOutcome {
    /// Proven optimal and verified by the exact check.
    Optimal {
        /// The selection.
        selected: Vec<bool>,
        /// Its cost (new sites).
        cost: f64,
        /// Lazy rounds used.
        rounds: usize,
        /// Constraints (walks) in the final programme.
        constraints: usize,
    },
    /// No selection of candidates covers this walk.
    Infeasible(Walk),
    /// A limit was reached; the best proven lower bound on the cost (0 if none).
    GaveUp {
        /// Lower bound on the cost of new sites.
        lower_bound_cost: f64,
        /// Why.
        reason: String,
    },
}

/// Solves an instance exactly, within limits; `warm` is a feasible
/// selection (e.g. the greedy's) seeding every branch and bound.
///
/// With whole-number costs the search stops as soon as the incumbent is
/// within less than 1 of the proven bound, which proves it optimal (every
/// selection's cost is a whole number); the relative MIP gap that gives this
/// is set from the warm start's cost.
pub fn solve(p: &CoverProblem, limits: IlpLimits, warm: Option<&[bool]>) -> IlpOutcome {
    let need_all = (p.k + 1) as f64;
    let integral = p
        .sites
        .iter()
        .all(|s| s.existing || (s.cost.fract() == 0.0 && s.cost <= 1e6));
    let ub = match warm {
        Some(w) => (0..p.sites.len())
            .filter(|&i| w[i] && !p.sites[i].existing)
            .map(|i| p.sites[i].cost)
            .sum::<f64>(),
        None => p.sites.iter().map(|s| s.cost).sum(),
    };
    let mut constraints: Vec<Vec<(u32, u32)>> = Vec::new();
    let mut seen: HashSet<Vec<(u32, u32)>> = HashSet::new();
    let mut selected = p.existing_selection();
    let mut lb: f64 = 0.0;
    for round in 1..=limits.max_rounds {
        let (res, walks) = cover::check_with_witnesses(p, &selected, usize::MAX);
        if res.feasible() {
            let cost = (0..p.sites.len())
                .filter(|&i| selected[i] && !p.sites[i].existing)
                .map(|i| p.sites[i].cost)
                .sum();
            return IlpOutcome::Optimal {
                selected,
                cost,
                rounds: round - 1,
                constraints: constraints.len(),
            };
        }
        let mut added = 0;
        for w in walks {
            // Passes per site, sorted: the constraint's coefficients.
            let mut c: Vec<(u32, u32)> = Vec::new();
            let mut s = w.sites.clone();
            s.sort_unstable();
            for x in s {
                match c.last_mut() {
                    Some(last) if last.0 == x => last.1 += 1,
                    _ => c.push((x, 1)),
                }
            }
            let fixed: u32 = c
                .iter()
                .filter(|(x, _)| p.sites[*x as usize].existing)
                .map(|c| c.1)
                .sum();
            let free: u32 = c
                .iter()
                .filter(|(x, _)| !p.sites[*x as usize].existing)
                .map(|c| c.1)
                .sum();
            if f64::from(fixed + free) < need_all {
                return IlpOutcome::Infeasible(w);
            }
            if seen.insert(c.clone()) {
                constraints.push(c);
                added += 1;
            }
        }
        if added == 0 || constraints.len() > limits.max_constraints {
            return IlpOutcome::GaveUp {
                lower_bound_cost: lb,
                reason: if added == 0 {
                    "no new constraint from the violations (rounding)".into()
                } else {
                    format!("more than {} walk constraints", limits.max_constraints)
                },
            };
        }
        // Variables: the sites appearing in some constraint.
        let mut var_of: Vec<Option<microlp::Variable>> = vec![None; p.sites.len()];
        let mut prob = microlp::Problem::new(microlp::OptimizationDirection::Minimize);
        for c in &constraints {
            for &(s, _) in c {
                if var_of[s as usize].is_none() {
                    let site = &p.sites[s as usize];
                    var_of[s as usize] = Some(if site.existing {
                        prob.add_var(0.0, (1.0, 1.0))
                    } else {
                        prob.add_binary_var(site.cost)
                    });
                }
            }
        }
        for c in &constraints {
            let expr: Vec<(microlp::Variable, f64)> = c
                .iter()
                .filter_map(|&(s, m)| var_of[s as usize].map(|v| (v, f64::from(m))))
                .collect();
            prob.add_constraint(expr.as_slice(), microlp::ComparisonOp::Ge, need_all);
        }
        let mut opts = microlp::SolveOptions::default();
        opts.node_limit = Some(limits.node_limit);
        if integral {
            opts.mip_gap = 0.99 / (ub + 1.0);
        }
        if let Some(w) = warm {
            opts.warm_start = Some(
                var_of
                    .iter()
                    .enumerate()
                    .filter_map(|(i, v)| v.map(|v| (v, if w[i] { 1.0 } else { 0.0 })))
                    .collect(),
            );
        }
        let proven = |sol: &microlp::Solution| -> Option<f64> {
            match sol.status() {
                microlp::SolutionStatus::Optimal => Some(sol.objective()),
                microlp::SolutionStatus::Feasible => sol
                    .stats()
                    .best_bound
                    .filter(|b| integral && sol.objective() - b < 1.0 - 1e-6)
                    .map(|_| sol.objective()),
            }
        };
        let sol = match prob.solve_with(opts) {
            Ok(microlp::SolveOutcome::Solution(s)) if proven(&s).is_some() => s,
            Ok(out) => {
                let b = match &out {
                    microlp::SolveOutcome::Solution(s) => s.stats().best_bound,
                    microlp::SolveOutcome::Interrupted(i) => i.stats().best_bound,
                };
                let b = b.map_or(0.0, |b| if integral { (b - 1e-6).ceil() } else { b });
                return IlpOutcome::GaveUp {
                    lower_bound_cost: lb.max(b),
                    reason: format!("branch and bound exceeded {} nodes", limits.node_limit),
                };
            }
            Err(microlp::Error::Infeasible) => {
                // Cannot happen (every constraint was checked satisfiable
                // alone, and all-ones satisfies all); treat as a give-up.
                return IlpOutcome::GaveUp {
                    lower_bound_cost: lb,
                    reason: "the solver reported infeasible".into(),
                };
            }
            Err(e) => {
                return IlpOutcome::GaveUp {
                    lower_bound_cost: lb,
                    reason: format!("solver: {e}"),
                }
            }
        };
        lb = lb.max(proven(&sol).unwrap_or(0.0));
        selected = p.existing_selection();
        for (i, v) in var_of.iter().enumerate() {
            if let Some(v) = v {
                if sol.var_value(*v) > 0.5 {
                    selected[i] = true;
                }
            }
        }
    }
    IlpOutcome::GaveUp {
        lower_bound_cost: lb,
        reason: format!("{} lazy rounds", limits.max_rounds),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::planner::network::cover::tests::random_problem;
    use crate::planner::network::cover::{check, Solved};
    use crate::planner::network::greedy::greedy;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    /// The cheapest feasible selection by enumerating all subsets of the
    /// non-installed sites (feasibility by the DP check, itself tested
    /// against walk enumeration).
    fn brute_optimum(p: &CoverProblem) -> Option<f64> {
        let free: Vec<usize> = (0..p.sites.len())
            .filter(|&i| !p.sites[i].existing)
            .collect();
        let mut best: Option<f64> = None;
        for mask in 0u32..(1 << free.len()) {
            let mut sel = p.existing_selection();
            let mut cost = 0.0;
            for (b, &i) in free.iter().enumerate() {
                if mask >> b & 1 == 1 {
                    sel[i] = true;
                    cost += p.sites[i].cost;
                }
            }
            if best.is_some_and(|b| cost >= b) {
                continue;
            }
            if check(p, &sel).feasible() {
                best = Some(cost);
            }
        }
        best
    }

    #[test]
    fn ilp_is_exact_against_subset_enumeration() {
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let (mut solved, mut infeasible) = (0, 0);
        for case in 0..250 {
            let p = random_problem(&mut rng, 9);
            let brute = brute_optimum(&p);
            match solve(&p, IlpLimits::default(), None) {
                IlpOutcome::Optimal { selected, cost, .. } => {
                    solved += 1;
                    assert!(check(&p, &selected).feasible(), "case {case}");
                    let b = brute.expect("brute force finds a solution too");
                    // Costs are whole numbers: equality to rounding.
                    assert!(
                        (cost - b).abs() < 1e-9,
                        "case {case}: ilp {cost}, brute {b}"
                    );
                    // The greedy is never better than the optimum.
                    if let Solved::Feasible(g) = greedy(&p) {
                        let gc: f64 = (0..g.len())
                            .filter(|&i| g[i] && !p.sites[i].existing)
                            .map(|i| p.sites[i].cost)
                            .sum();
                        assert!(gc >= cost - 1e-9, "case {case}");
                    }
                }
                IlpOutcome::Infeasible(_) => {
                    infeasible += 1;
                    assert!(brute.is_none(), "case {case}");
                }
                IlpOutcome::GaveUp { reason, .. } => panic!("case {case}: gave up: {reason}"),
            }
        }
        assert!(solved > 80 && infeasible > 5, "{solved} {infeasible}");
    }
}
