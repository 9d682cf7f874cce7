//! The source tree's shape, checked on every test run: layers import downward
//! only, no import circle between modules or between the files of a module,
//! and no source file grows past ~900 lines before its test module.
//!
//! The check reads `src/` as text. It resolves `crate::a::b` paths and
//! `super::x` paths that name a sibling file; glob and re-exported names are
//! attributed to the module that re-exports them, which is conservative for
//! the layer check (a module's `mod.rs` belongs to its own layer).

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// The layers, lowest first. A module may import its own layer or lower ones;
/// imports inside one layer must not form a circle.
const LAYERS: &[&[&str]] = &[
    &[
        "geodesy",
        "attitude",
        "decimal",
        "error",
        "units",
        "fsio",
        "elevation",
    ],
    &["network", "nav", "tags"],
    &["route", "matching", "sensors", "trajectory"],
    &["scenario"],
    &["sim"],
    &["planner"],
    &["report", "export"],
    &["workflow"],
];

/// Longest allowed source before a file's `#[cfg(test)]` module.
const MAX_LINES: usize = 900;

fn layer_of(module: &str) -> Option<usize> {
    LAYERS.iter().position(|l| l.contains(&module))
}

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).expect("reading src") {
        let p = entry.expect("dir entry").path();
        if p.is_dir() {
            rust_files(&p, out);
        } else if p.extension().is_some_and(|e| e == "rs") {
            out.push(p);
        }
    }
}

/// The file's code before its test module, without comment lines (doc
/// links name modules without importing them).
fn non_test(text: &str) -> String {
    let code = match text.find("#[cfg(test)]") {
        Some(i) => &text[..i],
        None => text,
    };
    code.lines()
        .map(|l| {
            if l.trim_start().starts_with("//") {
                ""
            } else {
                l
            }
        })
        .collect::<Vec<_>>()
        .join("\n")
}

/// Module path of a file below `src/`, e.g. `sim/run.rs` → ["sim", "run"],
/// `sim/mod.rs` → ["sim"].
fn module_path(rel: &Path) -> Vec<String> {
    let mut parts: Vec<String> = rel
        .iter()
        .map(|s| s.to_string_lossy().trim_end_matches(".rs").to_string())
        .collect();
    if parts.last().is_some_and(|s| s == "mod") {
        parts.pop();
    }
    parts
}

/// Identifiers following `prefix::` in `text` (lower-case path segments only).
fn paths_after<'a>(text: &'a str, prefix: &str) -> Vec<Vec<&'a str>> {
    let mut out = Vec::new();
    let mut rest = text;
    while let Some(i) = rest.find(prefix) {
        let before = rest[..i].chars().last();
        rest = &rest[i + prefix.len()..];
        if before.is_some_and(|c| c.is_alphanumeric() || c == '_' || c == ':') {
            continue;
        }
        let mut segs = Vec::new();
        let mut s = rest;
        loop {
            let end = s
                .find(|c: char| !(c.is_ascii_alphanumeric() || c == '_'))
                .unwrap_or(s.len());
            let seg = &s[..end];
            if seg.is_empty() || !seg.starts_with(|c: char| c.is_ascii_lowercase()) {
                break;
            }
            segs.push(seg);
            if s[end..].starts_with("::") {
                s = &s[end + 2..];
            } else {
                break;
            }
        }
        if !segs.is_empty() {
            out.push(segs);
        }
    }
    out
}

fn find_cycle(graph: &BTreeMap<String, BTreeSet<String>>) -> Option<Vec<String>> {
    // Depth-first search with colours; returns one circle if any.
    fn visit(
        n: &str,
        g: &BTreeMap<String, BTreeSet<String>>,
        state: &mut BTreeMap<String, u8>,
        stack: &mut Vec<String>,
    ) -> Option<Vec<String>> {
        state.insert(n.to_string(), 1);
        stack.push(n.to_string());
        for m in g.get(n).into_iter().flatten() {
            match state.get(m.as_str()).copied().unwrap_or(0) {
                1 => {
                    let i = stack.iter().position(|s| s == m).unwrap();
                    let mut c = stack[i..].to_vec();
                    c.push(m.clone());
                    return Some(c);
                }
                0 => {
                    if let Some(c) = visit(m, g, state, stack) {
                        return Some(c);
                    }
                }
                _ => {}
            }
        }
        stack.pop();
        state.insert(n.to_string(), 2);
        None
    }
    let mut state = BTreeMap::new();
    for n in graph.keys() {
        if state.get(n.as_str()).copied().unwrap_or(0) == 0 {
            let mut stack = Vec::new();
            if let Some(c) = visit(n, graph, &mut state, &mut stack) {
                return Some(c);
            }
        }
    }
    None
}

struct Tree {
    /// (path below src, module path, non-test text)
    files: Vec<(PathBuf, Vec<String>, String)>,
    /// Module paths that are files (for resolving `crate::a::b`).
    modules: BTreeSet<Vec<String>>,
}

fn read_tree() -> Tree {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut paths = Vec::new();
    rust_files(&src, &mut paths);
    paths.sort();
    let mut files = Vec::new();
    let mut modules = BTreeSet::new();
    for p in paths {
        let rel = p.strip_prefix(&src).unwrap().to_path_buf();
        let text = std::fs::read_to_string(&p).unwrap();
        let m = module_path(&rel);
        modules.insert(m.clone());
        files.push((rel, m, non_test(&text)));
    }
    Tree { files, modules }
}

/// The longest known module path that `segs` starts with.
fn resolve(modules: &BTreeSet<Vec<String>>, segs: &[&str]) -> Vec<String> {
    let mut best = vec![segs[0].to_string()];
    for k in 1..=segs.len() {
        let cand: Vec<String> = segs[..k].iter().map(|s| s.to_string()).collect();
        if modules.contains(&cand) {
            best = cand;
        }
    }
    best
}

#[test]
fn layers_import_downward_only_and_modules_form_no_circle() {
    let tree = read_tree();
    let mut module_graph: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    let mut violations = Vec::new();
    for (rel, m, text) in &tree.files {
        if m.is_empty() || m[0] == "main" || m[0] == "lib" || m[0] == "bin" {
            continue; // the binary and the crate root sit on top
        }
        let top = &m[0];
        let Some(own) = layer_of(top) else {
            violations.push(format!(
                "{}: module `{top}` has no layer in tests/it/architecture.rs",
                rel.display()
            ));
            continue;
        };
        for segs in paths_after(text, "crate::") {
            let other = segs[0];
            if other == top {
                continue;
            }
            module_graph
                .entry(top.clone())
                .or_default()
                .insert(other.to_string());
            match layer_of(other) {
                Some(l) if l <= own => {}
                Some(_) => violations.push(format!(
                    "{}: `{top}` imports the higher layer `{other}`",
                    rel.display()
                )),
                None => violations.push(format!(
                    "{}: imports `{other}`, which has no layer",
                    rel.display()
                )),
            }
        }
    }
    assert!(
        violations.is_empty(),
        "layering:\n{}",
        violations.join("\n")
    );
    if let Some(c) = find_cycle(&module_graph) {
        panic!("import circle between modules: {}", c.join(" -> "));
    }
}

#[test]
fn files_of_a_module_form_no_import_circle() {
    // Edges between files that are not `mod.rs` (a folder's `mod.rs` is its
    // facade: it declares and re-exports its children).
    let tree = read_tree();
    let mut graph: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for (rel, m, text) in &tree.files {
        if rel
            .file_name()
            .is_some_and(|f| f == "mod.rs" || f == "lib.rs" || f == "main.rs")
        {
            continue;
        }
        let me = m.join("::");
        let mut targets: Vec<Vec<String>> = Vec::new();
        for segs in paths_after(text, "crate::") {
            targets.push(resolve(&tree.modules, &segs));
        }
        let parent = &m[..m.len() - 1];
        for segs in paths_after(text, "super::") {
            let mut full: Vec<&str> = parent.iter().map(|s| s.as_str()).collect();
            full.extend(segs.iter().copied());
            let r = resolve(&tree.modules, &full);
            targets.push(r);
        }
        for t in targets {
            // Only file modules other than ourselves and other than facades.
            let is_file = tree
                .files
                .iter()
                .any(|(r, mm, _)| mm == &t && r.file_name().is_none_or(|f| f != "mod.rs"));
            let name = t.join("::");
            if is_file && name != me {
                graph.entry(me.clone()).or_default().insert(name);
            }
        }
    }
    if let Some(c) = find_cycle(&graph) {
        panic!("import circle between files: {}", c.join(" -> "));
    }
}

#[test]
fn no_source_file_is_longer_than_the_limit_before_its_tests() {
    let tree = read_tree();
    let long: Vec<String> = tree
        .files
        .iter()
        .filter_map(|(rel, _, text)| {
            let n = text.lines().count();
            (n > MAX_LINES).then(|| format!("{}: {n} lines", rel.display()))
        })
        .collect();
    assert!(
        long.is_empty(),
        "files over {MAX_LINES} lines before their test module:\n{}",
        long.join("\n")
    );
}

#[test]
fn the_checker_finds_paths_and_circles() {
    // The checker itself: a path parser and a circle finder that could fail.
    let p = paths_after(
        "use crate::sim::run::{a, b}; x = super::metrics::f();",
        "crate::",
    );
    assert_eq!(p, vec![vec!["sim", "run"]]);
    let p = paths_after(
        "let y = super::metrics::f(); let z = super::Foo;",
        "super::",
    );
    assert_eq!(p, vec![vec!["metrics", "f"]]);
    let mut g: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    g.entry("a".into()).or_default().insert("b".into());
    g.entry("b".into()).or_default().insert("c".into());
    assert!(find_cycle(&g).is_none());
    g.entry("c".into()).or_default().insert("a".into());
    assert_eq!(find_cycle(&g).unwrap(), vec!["a", "b", "c", "a"]);
}
