//! The house has no back-and-forth (issue 20): within each crate, no two top-level modules
//! import each other, and the GPU layer of the run time imports no pack, representation,
//! crowd or scene module (it takes plain GPU-ready data). Read from the sources: every
//! `crate::name` (and in the editor `super::name` / `crate::editor::name`) outside comments
//! and test modules counts as an import of `name`.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            rust_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

/// The code of a file: comment lines and everything from its first test module on left out;
/// a file that is a test module (`tests.rs`) gives nothing.
fn code(path: &Path) -> String {
    if path.file_name().is_some_and(|n| n == "tests.rs") {
        return String::new();
    }
    let text = std::fs::read_to_string(path).unwrap();
    let text = text.split("#[cfg(test)]").next().unwrap_or_default();
    text.lines()
        .filter(|l| !l.trim_start().starts_with("//"))
        .collect::<Vec<_>>()
        .join("\n")
}

/// Names following each of `prefixes` in `text` (`crate::pack::load` gives `pack`).
fn referenced(text: &str, prefixes: &[&str]) -> BTreeSet<String> {
    let mut out = BTreeSet::new();
    for prefix in prefixes {
        for (i, _) in text.match_indices(prefix) {
            // Whole paths only: `mycrate::` is not `crate::`.
            let before = text[..i].chars().next_back();
            if before.is_some_and(|c| c.is_alphanumeric() || c == '_') {
                continue;
            }
            let name: String = text[i + prefix.len()..]
                .chars()
                .take_while(|c| c.is_alphanumeric() || *c == '_')
                .collect();
            if !name.is_empty() {
                out.insert(name);
            }
        }
    }
    out
}

/// Top-level module of each source file under `src` → the top-level modules it imports.
fn module_graph(src: &Path, prefixes: &[&str]) -> BTreeMap<String, BTreeSet<String>> {
    let mut files = Vec::new();
    rust_files(src, &mut files);
    assert!(!files.is_empty(), "no sources under {}", src.display());
    let mut graph: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for f in files {
        let rel = f.strip_prefix(src).unwrap();
        let top = rel
            .components()
            .next()
            .unwrap()
            .as_os_str()
            .to_string_lossy()
            .trim_end_matches(".rs")
            .to_string();
        let deps = referenced(&code(&f), prefixes);
        let entry = graph.entry(top.clone()).or_default();
        entry.extend(deps.into_iter().filter(|d| *d != top));
    }
    graph
}

fn circles(graph: &BTreeMap<String, BTreeSet<String>>) -> Vec<String> {
    let mut out = Vec::new();
    for (a, deps) in graph {
        for b in deps {
            if a < b && graph.get(b).is_some_and(|d| d.contains(a)) {
                out.push(format!("{a} <-> {b}"));
            }
        }
    }
    out
}

#[test]
fn no_two_modules_import_each_other() {
    let root = repo();
    for (src, prefixes) in [
        (root.join("crates/polypostor-runtime/src"), &["crate::"][..]),
        (root.join("crates/polypostor-bake/src"), &["crate::"][..]),
        (root.join("src/editor"), &["super::", "crate::editor::"][..]),
    ] {
        let graph = module_graph(&src, prefixes);
        assert!(graph.len() > 5, "{}: {graph:?}", src.display());
        let found = circles(&graph);
        assert!(
            found.is_empty(),
            "{}: modules importing each other: {found:?}",
            src.display()
        );
    }
}

#[test]
fn the_gpu_layer_takes_plain_data() {
    let gpu = repo().join("crates/polypostor-runtime/src/gpu");
    let mut files = Vec::new();
    rust_files(&gpu, &mut files);
    for f in files {
        let deps = referenced(&code(&f), &["crate::"]);
        for format in ["pack", "reps", "crowd", "scene"] {
            assert!(
                !deps.contains(format),
                "{} imports crate::{format}: the renderers take gpu::inputs",
                f.display()
            );
        }
    }
}

/// The scan finds what it looks for (a circle planted in a made-up graph, and a reference).
#[test]
fn the_scan_sees_a_circle_and_a_reference() {
    assert_eq!(
        referenced(
            "use crate::pack::X; let y = mycrate::reps::Z; crate::gpu::f()",
            &["crate::"]
        ),
        ["gpu", "pack"].map(String::from).into_iter().collect()
    );
    let mut g: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    g.entry("a".into()).or_default().insert("b".into());
    g.entry("b".into()).or_default().insert("c".into());
    assert!(circles(&g).is_empty());
    g.entry("c".into()).or_default().insert("b".into());
    assert_eq!(circles(&g), ["b <-> c"]);
}
