//! A restarted HMM matcher (`HmmMatcher::restart`, what `match_rows` does
//! between the tracks of a file, keeping its buffers and network searches)
//! matches the next track exactly as a fresh matcher does: the same points,
//! confidences and breaks, whatever the previous track left behind (here an
//! off-road fix, a held break, a drift estimate, a full lag window).

use waymark::matching::{
    along_route, match_track, Fix, HmmMatcher, HmmParams, Matcher, TrackModel,
};
use waymark::network::{LoadOptions, Network};
use waymark::route::plan_route;

fn helsinki() -> Network {
    let p = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("maps/helsinki.osm.pbf");
    Network::load(&p, &LoadOptions::default()).unwrap()
}

fn track(net: &Network, from: [f64; 2], to: [f64; 2], seed: u64) -> Vec<Fix> {
    let route = plan_route(net, &[from, to]).unwrap();
    let model = TrackModel {
        spacing_m: 7.0,
        speed_mps: 10.0,
        drift_max_m: 30.0,
        noise_sigma_m: 3.0,
        heading_sigma_deg: None,
        seed,
    };
    along_route(net, &route, &model).fixes
}

#[test]
fn a_restarted_matcher_matches_as_a_fresh_one() {
    let net = helsinki();
    let mut a = track(&net, [60.1660, 24.9380], [60.1770, 24.9510], 3);
    // The first track ends off the map: the matcher holds an off-road break
    // for a next fix that never comes.
    let last = *a.last().unwrap();
    a.push(Fix {
        t_s: last.t_s + 1.0,
        enu: [last.enu[0] + 5_000.0, last.enu[1] + 5_000.0],
        heading_rad: None,
    });
    let b = track(&net, [60.1770, 24.9510], [60.1675, 24.9490], 4);
    assert!(a.len() > 200 && b.len() > 100, "{} {}", a.len(), b.len());
    let pa = HmmParams::default();
    // Other parameters for the second track, as a file's tracks get their
    // own from their σ̂.
    let pb = HmmParams {
        search_radius_m: 150.0,
        sigma_m: 7.0,
        drift_sigma_m: 12.0,
        ..HmmParams::default()
    };
    let mut fresh = HmmMatcher::new(&net, pb);
    let want = match_track(&mut fresh, &b);
    let mut m = HmmMatcher::new(&net, pa);
    let first = match_track(&mut m, &a);
    // Unmatched, and a break held for the next fix (recorded only when one
    // is matched: a restart must forget it).
    assert!(!first.last().unwrap().state.is_matched());
    assert!(m.breaks().is_empty());
    m.restart(pb);
    let got = match_track(&mut m, &b);
    assert_eq!(got.len(), want.len());
    for (g, w) in got.iter().zip(&want) {
        assert_eq!(g, w);
    }
    assert_eq!(m.breaks(), fresh.breaks());
    assert!(want.iter().filter(|p| p.state.is_matched()).count() > b.len() * 9 / 10);
}

/// A `FileMatcher` kept across files (its HMM matcher, buffers and the
/// tables of its network searches reused) gives exactly what `match_rows`
/// gives for each file when its searches are forgotten before it (cold),
/// and what `match_rows_with` gives with the cache kept (warm): the same
/// MATCHED.csv text, breaks, complete paths and parameters.
#[test]
fn a_file_matcher_kept_across_files_matches_as_match_rows() {
    use waymark::matching::inputs::read_track_file;
    use waymark::matching::options::MatchOptions;
    use waymark::matching::track::{
        match_rows, match_rows_with, matched_csv, FileMatcher, TrackOutcome,
    };
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/real");
    let net = Network::load(&dir.join("issue-13.osm"), &LoadOptions::default()).unwrap();
    let files: Vec<_> = ["issue-13.gpx", "issue-127.gpx", "issue-13.gpx"]
        .iter()
        .map(|f| read_track_file(&dir.join(f)).unwrap().0)
        .collect();
    let same = |a: &[TrackOutcome], b: &[TrackOutcome]| {
        assert_eq!(a.len(), b.len());
        for (x, y) in a.iter().zip(b) {
            assert_eq!(x.track_id, y.track_id);
            assert_eq!(x.rows, y.rows);
            assert_eq!(x.matched, y.matched);
            assert_eq!(x.breaks, y.breaks);
            assert_eq!(x.unmatched, y.unmatched);
            assert_eq!(x.path, y.path);
            assert_eq!(format!("{:?}", x.params), format!("{:?}", y.params));
        }
    };
    for opts in [
        MatchOptions::default(),
        MatchOptions {
            radius_m: Some(60.0),
            ..MatchOptions::default()
        },
    ] {
        let mut kept = FileMatcher::new(&net);
        let mut cache = None;
        for rows in &files {
            // Cold: as a new matcher's.
            kept.forget_searches();
            let (want_pts, want) = match_rows(&net, rows, &opts);
            let (pts, got) = kept.match_rows(rows, &opts);
            assert_eq!(
                matched_csv(&net, rows, &pts),
                matched_csv(&net, rows, &want_pts)
            );
            same(&got, &want);
            assert!(got[0].matched > 0 && !got[0].path.is_empty() || rows.len() < 3);
            // Warm: the cache of the files before kept.
            let (want_pts, want) = match_rows_with(&net, rows, &opts, &mut cache);
            let mut warm = FileMatcher::with_distances(&net, cache.take().unwrap());
            let (pts, got) = warm.match_rows(rows, &opts);
            assert_eq!(
                matched_csv(&net, rows, &pts),
                matched_csv(&net, rows, &want_pts)
            );
            same(&got, &want);
            cache = Some(warm.into_distances());
        }
    }
}

/// The streaming match by a `FileMatcher` kept across files writes what
/// `match_csv_stream` writes for each file (searches forgotten before each:
/// a cold start), byte for byte, with the same summary.
#[test]
fn a_file_matcher_kept_across_streamed_files_matches_as_a_new_one() {
    use waymark::matching::inputs::read_track_file;
    use waymark::matching::options::MatchOptions;
    use waymark::matching::stream::match_csv_stream;
    use waymark::matching::track::FileMatcher;
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/real");
    let net = Network::load(&dir.join("issue-13.osm"), &LoadOptions::default()).unwrap();
    let tmp = tempfile::tempdir().unwrap();
    // Two CSV files of two tracks each, from the committed GPX traces.
    let mut files = Vec::new();
    for (k, names) in [
        ["issue-13.gpx", "issue-127.gpx"],
        ["issue-127.gpx", "issue-13.gpx"],
    ]
    .iter()
    .enumerate()
    {
        let mut text = String::from("t_s,lat,lon,track_id\n");
        for (j, name) in names.iter().enumerate() {
            let (rows, _) = read_track_file(&dir.join(name)).unwrap();
            for (i, r) in rows.iter().enumerate() {
                text += &format!("{},{},{},t{j}\n", i, r.lat, r.lon);
            }
        }
        let p = tmp.path().join(format!("f{k}.csv"));
        std::fs::write(&p, text).unwrap();
        files.push(p);
    }
    let opts = MatchOptions::default();
    let out = tmp.path().join("m.csv");
    let mut kept = FileMatcher::new(&net);
    for _ in 0..2 {
        for f in &files {
            let mut want = Vec::new();
            let w = match_csv_stream(&net, f, &opts, true, &mut want, &out)
                .unwrap()
                .unwrap();
            kept.forget_searches();
            let mut got = Vec::new();
            let g = kept
                .match_csv_stream(f, &opts, true, &mut got, &out)
                .unwrap()
                .unwrap();
            assert_eq!(
                String::from_utf8(got).unwrap(),
                String::from_utf8(want).unwrap()
            );
            assert_eq!(g.tracks.len(), 2);
            assert_eq!(format!("{:?}", g.tracks), format!("{:?}", w.tracks));
            assert!(g.tracks.iter().all(|t| t.matched == t.points));
        }
    }
}

/// `FileMatcher::match_rows_into` with one `FileMatch` kept across files
/// (its outcomes, row lists and paths' section lists reused, extra outcomes
/// dropped) gives what a new `match_rows` gives for each file, both models:
/// the same MATCHED.csv text, tracks in order of first appearance (as
/// `group_tracks` gives them), breaks, unmatched runs, complete paths and
/// parameters. The files have 1, 3, 12 (more than the grouping's linear
/// scan, ids interleaved) and 2 tracks (one revisited after the other).
#[test]
fn a_kept_file_match_is_filled_as_a_new_one() {
    use waymark::matching::inputs::read_track_file;
    use waymark::matching::options::MatchOptions;
    use waymark::matching::track::{
        group_tracks, match_rows, matched_csv, FileMatch, FileMatcher, TrackRow,
    };
    use waymark::matching::HmmModel;
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/real");
    for (map, track) in [
        ("issue-13.osm", "issue-13.gpx"),
        ("fmm-network.geojson", "fmm-trips.geojson"),
    ] {
        let net = Network::load(&dir.join(map), &LoadOptions::default()).unwrap();
        let (rows, _) = read_track_file(&dir.join(track)).unwrap();
        let with_ids = |id: &dyn Fn(usize) -> String| -> Vec<TrackRow> {
            rows.iter()
                .enumerate()
                .map(|(i, r)| TrackRow {
                    track_id: id(i),
                    ..r.clone()
                })
                .collect()
        };
        let n = rows.len();
        let files = [
            with_ids(&|_| String::new()),
            rows.clone(),
            with_ids(&|i| format!("t{}", i % 12)),
            with_ids(&|i| {
                if i < n / 3 || i >= 2 * n / 3 {
                    "a"
                } else {
                    "b"
                }
                .into()
            }),
            rows.clone(),
        ];
        for model in [HmmModel::Drift, HmmModel::Independent] {
            let opts = MatchOptions {
                model,
                ..MatchOptions::default()
            };
            let mut kept = FileMatcher::new(&net);
            let mut out = FileMatch::default();
            for rows in &files {
                kept.forget_searches();
                kept.match_rows_into(rows, &opts, &mut out);
                let (want_pts, want) = match_rows(&net, rows, &opts);
                assert_eq!(
                    matched_csv(&net, rows, &out.points),
                    matched_csv(&net, rows, &want_pts)
                );
                let groups = group_tracks(rows);
                assert_eq!(out.tracks.len(), groups.len());
                assert_eq!(want.len(), groups.len());
                for ((x, y), (id, idx)) in out.tracks.iter().zip(&want).zip(&groups) {
                    assert_eq!((&x.track_id, &x.rows), (id, idx));
                    assert_eq!(x.track_id, y.track_id);
                    assert_eq!(x.rows, y.rows);
                    assert_eq!(x.matched, y.matched);
                    assert_eq!(x.breaks, y.breaks);
                    assert_eq!(x.unmatched, y.unmatched);
                    assert_eq!(x.path, y.path);
                    assert_eq!(format!("{:?}", x.params), format!("{:?}", y.params));
                }
                assert!(out.tracks.iter().map(|t| t.matched).sum::<usize>() > 0);
            }
        }
    }
}
