//! Every route-plan tag carries its reason (issue 13 point 7, issue 16
//! point 3): the figures the placement worked with — the reach of the fix
//! `k + 1` tags back (or of the start), where the tag stands in it, and
//! what its own fix gives — in `plan.json` and in every tag export.

use std::path::Path;
use waymark::planner::plan;
use waymark::sim::Scenario;

fn check(name: &str) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("scenarios")
        .join(name);
    let scn = Scenario::load(&path).expect("scenario loads");
    let p = plan(&scn, 1, false).expect("plan");
    assert!(!p.tags.is_empty(), "{name}: a plan with tags");
    let k = p.tolerate_missed_reads;
    let end = |e: f64| {
        if e >= p.route_length_m - 1e-6 {
            format!("the route's end ({:.0} m)", p.route_length_m)
        } else {
            format!("{e:.0} m")
        }
    };
    for (j, t) in p.tags.iter().enumerate() {
        assert!(!t.reason.is_empty(), "{name} {}", t.tag_id);
        // Its own reach.
        assert!(
            t.reason
                .ends_with(&format!("holds the bound to {}", end(t.reach_m))),
            "{name}: {}",
            t.reason
        );
        if t.existing {
            continue;
        }
        // The anchor's reach, end and length, recomputed here.
        let (at, reach) = match j.checked_sub(k + 1) {
            None => (0.0, p.start_reach_m),
            Some(a) => (p.tags[a].route_distance_m, p.tags[a].reach_m),
        };
        let figures = format!(
            "holds the {:.0} m bound to {} (reach {:.0} m)",
            p.requirement_m,
            end(reach),
            reach.min(p.route_length_m) - at
        );
        assert!(
            t.reason.contains(&figures),
            "{name}: {figures} in {}",
            t.reason
        );
        // The plan keeps each tag within its anchor's reach.
        assert!(t.reason.contains("within it"), "{name}: {}", t.reason);
    }
    // The exports carry the same reasons, one per new tag.
    let (recs, _) = p.export(&scn).expect("export");
    let new: Vec<&str> = p
        .tags
        .iter()
        .filter(|t| !t.existing)
        .map(|t| t.reason.as_str())
        .collect();
    let exported: Vec<&str> = recs.iter().map(|r| r.reason.as_deref().unwrap()).collect();
    assert_eq!(exported, new, "{name}");
    let csv = waymark::export::tags_csv(&recs, &waymark::export::ExportMetadata::new(None));
    assert!(
        csv.contains("holds the bound to"),
        "{name}: tags.csv reasons"
    );
}

#[test]
fn demo_tags_carry_their_reasons() {
    check("demo.toml");
}

#[test]
fn helsinki_tactical_tags_carry_their_reasons() {
    check("helsinki-plan-tactical.toml");
}
