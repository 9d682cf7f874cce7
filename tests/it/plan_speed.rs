//! Planning speed (issue 14), asserted on the planner's own filter-step
//! counter (`Budget::steps`, `Plan::filter_passes`), never on time: the
//! early stop of the missed-tag windows gives the same worst bound for less
//! filter work, and small route plans stay within a pass budget.

use std::path::Path;
use waymark::planner::{generalized_lambda_max, plan, Budget};
use waymark::sim::tags::Mounting;
use waymark::sim::{Scenario, TruthSource};

fn scenario(name: &str) -> Scenario {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("scenarios")
        .join(name);
    Scenario::load(&path).expect("scenario loads")
}

#[test]
fn generalized_eigenvalue_matches_closed_forms() {
    use waymark::nav::ekf::{Mat, N};
    // Diagonal: the largest ratio of the diagonals.
    let u = Mat::from_fn(|i, j| {
        if i == j {
            1e-12 * (1.0 + i as f64)
        } else {
            0.0
        }
    });
    let p = Mat::from_fn(|i, j| {
        if i == j {
            u[(i, i)] * if i == 7 { 3.5 } else { 0.5 }
        } else {
            0.0
        }
    });
    assert!((generalized_lambda_max(&p, &u) - 3.5).abs() < 1e-12);
    // P = c·U for a full U: λ = c.
    let a = Mat::from_fn(|i, j| ((i * N + j) as f64 * 0.37).sin());
    let u = a * a.transpose() + Mat::identity() * 0.1;
    let l = generalized_lambda_max(&(u * 2.25), &u);
    assert!((l - 2.25).abs() < 1e-9, "{l}");
    // P ≤ U with one direction equal: λ = 1.
    let mut p = u * 0.25;
    let v = u.column(3).into_owned();
    // U e₃ e₃ᵀ U / U₃₃ is the part of U along its 3rd conjugate direction.
    p += (v * v.transpose()) * (0.75 / u[(3, 3)]);
    let l = generalized_lambda_max(&p, &u);
    assert!((l - 1.0).abs() < 1e-9, "{l}");
}

/// The missed-tag windows of a uniform layout, run to the end of the route
/// (`worst_bound_from`) and stopped once settled (`worst_bound_settled`):
/// the same worst bound, for at least a fifth fewer filter steps (measured:
/// 397,153 against 644,180 steps; the windows stop once the filters that
/// missed a tag have re-converged close enough to the all-read one).
#[test]
fn settled_windows_give_the_same_worst_bound_for_fewer_steps() {
    let scn = scenario("demo.toml");
    let truth = TruthSource::new(&scn).expect("truth");
    let budget = Budget::new(&scn, &truth, truth.network().map(|n| &**n));
    let samples = budget.samples();
    // A tag every 300 m.
    let mut next = 300.0;
    let mut fixes: Vec<(usize, Mounting)> = Vec::new();
    for (i, s) in samples.iter().enumerate() {
        if s.avp.distance_m >= next {
            fixes.push((i, Mounting::RoadSurface));
            next += 300.0;
        }
    }
    assert!(fixes.len() >= 10, "{}", fixes.len());
    let at: Vec<f64> = fixes
        .iter()
        .map(|&(i, _)| samples[i].avp.distance_m)
        .collect();
    let all = budget.all_read(&fixes, 50.0, &at);
    assert_eq!(all.sites.len(), fixes.len());
    let (mut full_steps, mut settled_steps) = (0, 0);
    for k in [1usize, 2] {
        for d in 0..fixes.len() + 1 - k {
            let s0 = budget.steps();
            let full = budget.worst_bound_from(
                fixes[d].0,
                all.sites[d].filter.clone(),
                &fixes[d + k..],
                f64::INFINITY,
            );
            let s1 = budget.steps();
            let settled = budget.worst_bound_settled(
                fixes[d].0,
                all.sites[d].filter.clone(),
                &all,
                d + k,
                f64::INFINITY,
                0.0,
            );
            let s2 = budget.steps();
            // Exact: the stop only skips samples whose bound cannot exceed
            // the worst so far.
            assert!(
                (full - settled).abs() <= 1e-12 * full,
                "k {k} window {d}: {full} vs {settled}"
            );
            full_steps += s1 - s0;
            settled_steps += s2 - s1;
        }
    }
    assert!(
        10 * settled_steps < 8 * full_steps,
        "settled {settled_steps} steps, full {full_steps}"
    );
}

/// Small route plans in filter passes (before issue 14: demo 177.6,
/// helsinki-plan-tactical about 100; second round 42.5 and 12.8; third
/// 19.8 and 9.2; 6.7 and 5.3; measured now: 4.21 and 3.93, held to issue
/// 14's 5, see BENCHMARKS.md): the
/// reaches are computed only for the sites the exact placement's search
/// gets to, shared runs show most of those short of the end without their
/// reach, the missed-tag windows stop once settled, and runs that read no
/// tag are carried by the tag-free pass's stretch maps. The plans themselves are asserted by
/// tests/it/plan_regression.rs.
#[test]
fn small_route_plans_stay_within_their_pass_budget() {
    for (name, most) in [("demo.toml", 5.0), ("helsinki-plan-tactical.toml", 5.0)] {
        let scn = scenario(name);
        let p = plan(&scn, 1, false).expect("plan");
        assert!(
            p.filter_passes > 1.0 && p.filter_passes <= most,
            "{name}: {} passes",
            p.filter_passes
        );
        assert!(p.predicted_max_bound95_missed_m.is_some(), "{name}");
    }
}

/// The uniform baseline's search (issue 14, point 2): at most 20 filter
/// passes for its covariance checks (before: the first check alone, 204
/// tags every 20 m, ran each of its 204 one-tag-missed windows to the
/// route's end, about 100 passes), its Monte Carlo runs apart.
#[test]
fn uniform_baseline_search_within_twenty_passes() {
    use waymark::planner::{uniform_baseline, PlannerSettings};
    let scn = scenario("demo.toml");
    let truth = TruthSource::new(&scn).expect("truth");
    let settings = PlannerSettings::from_scenario(&scn).expect("settings");
    let b = uniform_baseline(&scn, &truth, &settings, 1, 1, 0.99)
        .expect("baseline")
        .expect("a uniform spacing passes");
    assert!(
        b.filter_passes >= 1.0 && b.filter_passes <= 20.0,
        "{} passes",
        b.filter_passes
    );
    assert!(b.tried.len() >= 3, "{:?}", b.tried);
    // Issue 14 point 2, "plus its own Monte Carlo validation": the search
    // bisects on the covariance check and simulates only the spacing it
    // found (here it passes the Monte Carlo), not every spacing on the way.
    let simulated: Vec<_> = b.tried.iter().filter(|t| !t.1.is_nan()).collect();
    assert_eq!(simulated.len(), 1, "{:?}", b.tried);
    assert_eq!(simulated[0].0, b.spacing_m, "{:?}", b.tried);
}

/// Sites shown short of the route's end by shared runs (one run reading the
/// tags of several consecutive sites: `LazyReaches::reaches_end`) really
/// are: every answer equals what the site's own reach, computed one by one
/// (`Budget::reaches`), says, on the demo's first 65 candidate sites (the
/// first whose reach is the route's end is the 60th, at 1200 m), for fewer
/// filter steps.
#[test]
fn shared_runs_answer_reaches_end_exactly_for_fewer_steps() {
    let scn = scenario("demo.toml");
    let truth = TruthSource::new(&scn).expect("truth");
    let budget = Budget::new(&scn, &truth, truth.network().map(|n| &**n));
    let at: Vec<f64> = (1..=65).map(|i| 20.0 * i as f64).collect();
    let (_, sites) = budget.tag_free(20.0, &at);
    assert_eq!(sites.len(), at.len());
    let m = vec![Mounting::RoadSurface; sites.len()];
    let (req, length) = (20.0, budget.length_m());
    let s0 = budget.steps();
    let exact = budget.reaches(&sites, &m, req);
    let exact_steps = budget.steps() - s0;
    let lazy = budget.lazy_reaches(&sites, &m, req, None).certifying();
    let s1 = budget.steps();
    let answers: Vec<bool> = (0..sites.len()).map(|i| lazy.reaches_end(i)).collect();
    let shared_steps = budget.steps() - s1;
    for (i, (&a, e)) in answers.iter().zip(&exact).enumerate() {
        assert_eq!(a, e.1 >= length, "site {i}: reach {}", e.1);
    }
    let reaching = answers.iter().filter(|&&a| a).count();
    assert!(reaching > 0 && reaching < answers.len(), "{reaching}");
    assert!(lazy.certified() > 0);
    eprintln!(
        "shown short {} of {}, steps {shared_steps} against {exact_steps}",
        lazy.certified(),
        answers.len()
    );
    // Measured: 58 of the 65 shown short, 831,468 steps against 1,870,656
    // (0.44; the 6 sites reaching the end each cost a run to the end).
    assert!(
        (shared_steps as f64) < 0.8 * exact_steps as f64,
        "{shared_steps} against {exact_steps}"
    );
}

/// The tag-free pass's stretch maps (module `planner::stretch`: composed
/// covariance maps and an interior upper bound per stretch) give every
/// demo site exactly the reach the filter stepped sample by sample gives
/// (same floating-point numbers), at two requirements, for less work
/// (measured: 346k and 609k steps against 4.2 M and 2.1 M; 13.4 and 14.4
/// passes with the maps' building and applications counted, against 79.3
/// and 38.9).
#[test]
fn stretch_maps_give_the_stepped_reaches() {
    let scn = scenario("demo.toml");
    let truth = TruthSource::new(&scn).expect("truth");
    let budget = Budget::new(&scn, &truth, truth.network().map(|n| &**n));
    let length = budget.length_m();
    let sites_m: Vec<f64> = (1..)
        .map(|j| 20.0 * j as f64)
        .take_while(|&d| d < length)
        .collect();
    let (_, sites) = budget.tag_free(20.0, &sites_m);
    assert!(sites.len() > 200, "{}", sites.len());
    let mountings = vec![Mounting::RoadSurface; sites.len()];
    for req in [20.0, 8.0] {
        let (s0, p0) = (budget.steps(), budget.passes());
        let stepped = reaches_stepped(&budget, &sites, req);
        let (s1, p1) = (budget.steps(), budget.passes());
        let (j0, r0) = (budget.jumps(), budget.restarts());
        let mapped = budget.reaches(&sites, &mountings, req);
        let (s2, p2) = (budget.steps(), budget.passes());
        let differ: Vec<_> = stepped
            .iter()
            .zip(&mapped)
            .enumerate()
            .filter(|(_, (a, b))| a != b)
            .collect();
        assert!(differ.is_empty(), "req {req}: {differ:?}");
        // Not all reaches run to the end: some cross inside the route.
        assert!(stepped.iter().any(|r| r.1 < length - 100.0));
        assert!(budget.jumps() > j0);
        // Some replays started at a restart point inside their stretch:
        // the equality above covers them.
        assert!(budget.restarts() > r0);
        // Less work in all, the maps' building and applications counted.
        assert!((p2 - p1) * 2.0 < p1 - p0, "{} vs {}", p2 - p1, p1 - p0);
        assert!((s2 - s1) * 3 < s1 - s0, "{} vs {}", s2 - s1, s1 - s0);
    }
    // The missed-tag windows of a tag every 600 m: the worst bound carried
    // by the maps (where a stretch cannot raise it; after the last fix,
    // replaying only the stretches that may exceed it) is the stepped one.
    let fixes: Vec<(usize, Mounting)> = sites
        .iter()
        .skip(29)
        .step_by(30)
        .map(|s| (s.sample, Mounting::RoadSurface))
        .collect();
    let at: Vec<f64> = fixes
        .iter()
        .map(|&(i, _)| budget.samples()[i].avp.distance_m)
        .collect();
    let all = budget.all_read(&fixes, 50.0, &at);
    let j0 = budget.jumps();
    // The last window misses the last tag: the largest bound to the end
    // (`max_to_end`) from its start.
    for d in 0..fixes.len() {
        let stepped = budget.worst_bound_from(
            fixes[d].0,
            all.sites[d].filter.clone(),
            &fixes[d + 1..],
            f64::INFINITY,
        );
        let mapped = budget.worst_bound_settled(
            fixes[d].0,
            all.sites[d].filter.clone(),
            &all,
            d + 1,
            f64::INFINITY,
            0.0,
        );
        // Round-off of the maps' covariances against the stepped ones
        // (measured: at most 2.5e-14 relative).
        assert!(
            (stepped - mapped).abs() <= 1e-9 * stepped,
            "window {d}: {stepped} vs {mapped}"
        );
    }
    assert!(budget.jumps() > j0);
}

/// Each site's bound after a road-surface fix and its reach, stepping the
/// filter through every sample (as `Budget::reaches` did before the
/// stretch maps).
fn reaches_stepped(budget: &Budget, sites: &[waymark::planner::Site], req: f64) -> Vec<(f64, f64)> {
    sites
        .iter()
        .map(|site| {
            let mut f = site.filter.clone();
            budget.apply_fix(site.sample, &mut f, Mounting::RoadSurface);
            let b0 = budget.bound(&f.position_cov_enu());
            if b0 > req {
                return (b0, site.distance_m);
            }
            let mut reach = budget.length_m();
            let mut prev = site.distance_m;
            budget.run(site.sample, &mut f, |i, f| {
                if budget.bound(&f.position_cov_enu()) > req {
                    reach = prev;
                    return false;
                }
                prev = budget.samples()[i].avp.distance_m;
                true
            });
            (b0, reach)
        })
        .collect()
}

/// The lower bound's optimistic snapshots (a fix read at every site)
/// carried by the stretch maps and the sites' prefix maps
/// (`Budget::optimistic_sites`) against the stepped pass
/// (`Budget::snapshots` with every fix): each carried covariance lies
/// below the stepped one (generalized eigenvalue at most 1: the maps'
/// covariances are lowered by 1e-9 relative, more than their round-off)
/// and within 1e-6 of it, the reaches from them are the stepped ones, and
/// the pass steps far fewer samples. Sites every 20 m (several to a
/// stretch: stepped from the first one's fix) and every 100 m (one to a
/// stretch: carried to each site).
#[test]
fn optimistic_snapshots_by_the_maps_are_the_stepped_ones() {
    let scn = scenario("demo.toml");
    let truth = TruthSource::new(&scn).expect("truth");
    let budget = Budget::new(&scn, &truth, truth.network().map(|n| &**n));
    let length = budget.length_m();
    let sites_m: Vec<f64> = (1..)
        .map(|j| 20.0 * j as f64)
        .take_while(|&d| d < length)
        .collect();
    let (_, all_sites) = budget.tag_free(20.0, &sites_m);
    for every in [1usize, 5] {
        let sites: Vec<_> = all_sites
            .iter()
            .skip(every - 1)
            .step_by(every)
            .cloned()
            .collect();
        let mountings = vec![Mounting::RoadSurface; sites.len()];
        let fixes: Vec<(usize, Mounting)> = sites
            .iter()
            .map(|s| (s.sample, Mounting::RoadSurface))
            .collect();
        let at: Vec<f64> = sites.iter().map(|s| s.distance_m).collect();
        let s0 = budget.steps();
        let (_, stepped) = budget.snapshots(&fixes, 20.0, &at);
        let s1 = budget.steps();
        let carried = budget.optimistic_sites(&sites, &mountings).expect("maps");
        let s2 = budget.steps();
        assert_eq!(stepped.len(), carried.len());
        for (a, b) in stepped.iter().zip(&carried) {
            assert_eq!((a.sample, a.distance_m), (b.sample, b.distance_m));
            let up = generalized_lambda_max(b.filter.covariance(), a.filter.covariance());
            let down = generalized_lambda_max(a.filter.covariance(), b.filter.covariance());
            assert!(
                up <= 1.0 && down <= 1.0 + 1e-6,
                "every {every}, sample {}: {up} {down}",
                a.sample
            );
        }
        // The same reaches; the bound after each fix at most the stepped
        // one, and within 1e-8 of it.
        for req in [8.0, 20.0] {
            let a = budget.reaches(&stepped, &mountings, req);
            let b = budget.reaches(&carried, &mountings, req);
            for (n, (x, y)) in a.iter().zip(&b).enumerate() {
                assert_eq!(x.1, y.1, "every {every}, req {req}, site {n}");
                assert!(y.0 <= x.0 && y.0 >= x.0 * (1.0 - 1e-8), "{x:?} {y:?}");
            }
        }
        // Fewer steps: with several sites to a stretch (every 20 m) most
        // of it is stepped from the first one's fix; with one (every
        // 100 m) only the samples from each fix to the next boundary.
        let fewer = if every == 1 { 1 } else { 4 };
        assert!(
            (s2 - s1) * fewer < s1 - s0,
            "every {every}: {} vs {}",
            s2 - s1,
            s1 - s0
        );
    }
}

/// The missed-read bound's windows (`Budget::missed_worst`): only the
/// windows that may hold the largest bound are run exactly, the others
/// shown lower by runs settled at a lower bound of it (module
/// `planner::output`); the largest is the one every window run exactly
/// gives, for less counted work. Demo, a tag every 300 m (and a denser
/// every 150 m, where the windows' peaks are close together), `k` = 1, 2.
#[test]
fn missed_worst_runs_only_the_candidate_windows() {
    let scn = scenario("demo.toml");
    let truth = TruthSource::new(&scn).expect("truth");
    let budget = Budget::new(&scn, &truth, truth.network().map(|n| &**n));
    // The stretch maps (the candidates need them): the tag-free pass, with
    // candidate sites every 50 m (a stretch ends after one).
    let length = budget.length_m();
    let sites_m: Vec<f64> = (1..)
        .map(|j| 50.0 * j as f64)
        .take_while(|&d| d < length)
        .collect();
    let _ = budget.tag_free(50.0, &sites_m);
    let samples = budget.samples();
    for spacing in [300.0, 150.0] {
        let mut next = spacing;
        let mut fixes: Vec<(usize, Mounting)> = Vec::new();
        for (i, s) in samples.iter().enumerate() {
            if s.avp.distance_m >= next {
                fixes.push((i, Mounting::RoadSurface));
                next += spacing;
            }
        }
        assert!(fixes.len() >= 10, "{}", fixes.len());
        let at: Vec<f64> = fixes
            .iter()
            .map(|&(i, _)| samples[i].avp.distance_m)
            .collect();
        let all = budget.all_read(&fixes, 50.0, &at);
        for k in [1usize, 2] {
            let s0 = budget.passes();
            let every = (0..fixes.len() + 1 - k)
                .map(|d| {
                    budget.worst_bound_settled(
                        fixes[d].0,
                        all.sites[d].filter.clone(),
                        &all,
                        d + k,
                        f64::INFINITY,
                        0.0,
                    )
                })
                .fold(0.0, f64::max);
            let s1 = budget.passes();
            let fast = budget.missed_worst(&all, k, f64::INFINITY);
            let s2 = budget.passes();
            // The same windows run the same way: equal up to the stretch
            // nodes a run may use once built (a node's map instead of its
            // stretches' maps: round-off, ≈ 1e-12 relative measured).
            assert!(
                (fast - every).abs() <= 1e-12 * every,
                "every {spacing} m, k {k}: {fast} vs {every}"
            );
            assert!(every > all.grid_max, "{every} vs {}", all.grid_max);
            // Less counted work (steps, maps and anchors, in passes;
            // measured 0.99 / 1.12 / 1.22 / 1.16 against 1.89 / 1.61 /
            // 2.59 / 2.85).
            assert!(
                (s2 - s1) < 0.8 * (s1 - s0),
                "every {spacing} m, k {k}: {} passes against {}",
                s2 - s1,
                s1 - s0
            );
        }
    }
}
