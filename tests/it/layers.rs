//! The library's modules import each other one way only: the graph of
//! `crate::MODULE` references between the top-level modules of `src/` (a
//! folder is one module) has no cycle, and no module imports one of a higher
//! layer ([`LAYERS`], ARCHITECTURE.md). Doc comments, `#[cfg(test)]`
//! modules and `tests.rs` files are not imports and are left out.

use crate::util::root;
use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

/// The top-level module a file of `src/` belongs to.
fn module_of(rel: &Path) -> Option<String> {
    let first = rel.components().next()?.as_os_str().to_str()?.to_string();
    let name = first.strip_suffix(".rs").unwrap_or(&first).to_string();
    (name != "lib" && name != "main").then_some(name)
}

fn rust_files(dir: &Path, out: &mut Vec<std::path::PathBuf>) {
    for e in std::fs::read_dir(dir).expect("read src") {
        let p = e.expect("dir entry").path();
        if p.is_dir() {
            rust_files(&p, out);
        } else if p.extension().is_some_and(|x| x == "rs")
            && p.file_name().is_some_and(|n| n != "tests.rs")
        {
            out.push(p);
        }
    }
}

/// The code of a file without its test module and comments.
fn code(text: &str) -> String {
    let end = text
        .find("mod tests {")
        .map(|i| text[..i].rfind("#[cfg(test)]").unwrap_or(i))
        .unwrap_or(text.len());
    text[..end]
        .lines()
        .filter(|l| !l.trim_start().starts_with("//"))
        .collect::<Vec<_>>()
        .join("\n")
}

fn graph() -> BTreeMap<String, BTreeSet<String>> {
    let src = root().join("src");
    let mut files = vec![];
    rust_files(&src, &mut files);
    let modules: BTreeSet<String> = files
        .iter()
        .filter_map(|f| module_of(f.strip_prefix(&src).expect("under src")))
        .collect();
    let mut g: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for f in &files {
        let Some(from) = module_of(f.strip_prefix(&src).expect("under src")) else {
            continue;
        };
        let text = code(&std::fs::read_to_string(f).expect("read source"));
        let deps = g.entry(from.clone()).or_default();
        for (i, _) in text.match_indices("crate::") {
            let rest = &text[i + "crate::".len()..];
            let name: String = rest
                .chars()
                .take_while(|c| c.is_alphanumeric() || *c == '_')
                .collect();
            if name != from && modules.contains(&name) {
                deps.insert(name);
            }
        }
        // `use crate::{a, b::c}` groups.
        if let Some(i) = text.find("use crate::{") {
            let group = &text[i + "use crate::{".len()..];
            let group = &group[..group.find("};").unwrap_or(group.len())];
            for part in group.split(',') {
                let name: String = part
                    .trim()
                    .chars()
                    .take_while(|c| c.is_alphanumeric() || *c == '_')
                    .collect();
                if name != from && modules.contains(&name) {
                    deps.insert(name);
                }
            }
        }
    }
    g
}

/// A cycle of the graph, if there is one.
fn find_cycle(g: &BTreeMap<String, BTreeSet<String>>) -> Option<Vec<String>> {
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
                    let at = stack.iter().position(|s| s == m).expect("on the stack");
                    let mut cycle = stack[at..].to_vec();
                    cycle.push(m.clone());
                    return Some(cycle);
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
    for n in g.keys() {
        if state.get(n.as_str()).copied().unwrap_or(0) == 0 {
            let mut stack = vec![];
            if let Some(c) = visit(n, g, &mut state, &mut stack) {
                return Some(c);
            }
        }
    }
    None
}

/// The layers, lowest first; a module may import modules of its own layer
/// or lower ones only.
const LAYERS: [&[&str]; 10] = [
    &["model"],
    &["estimators", "transport"],
    &["scenario"],
    &["protocol"],
    &["world"],
    &["engine"],
    &["runtime"],
    &["pipeline"],
    &["plot", "report"],
    &["cli", "fuzz"],
];

fn layer(module: &str) -> Option<usize> {
    LAYERS.iter().position(|l| l.contains(&module))
}

/// Imports of a module of a higher layer, as `(from, to)`.
fn upward(g: &BTreeMap<String, BTreeSet<String>>) -> Vec<(String, String)> {
    let mut out = vec![];
    for (from, deps) in g {
        for to in deps {
            if layer(to) > layer(from) {
                out.push((from.clone(), to.clone()));
            }
        }
    }
    out
}

#[test]
fn library_modules_import_each_other_without_cycles() {
    let g = graph();
    assert!(
        g["pipeline"].contains("engine") && g["engine"].contains("protocol"),
        "the scan sees imports: {g:?}"
    );
    if let Some(c) = find_cycle(&g) {
        panic!("import cycle between modules: {}", c.join(" -> "));
    }
}

#[test]
fn every_top_level_module_has_a_layer_and_imports_none_above_it() {
    let g = graph();
    let unplaced: Vec<&String> = g.keys().filter(|m| layer(m).is_none()).collect();
    assert!(unplaced.is_empty(), "modules without a layer: {unplaced:?}");
    assert_eq!(g.len(), LAYERS.iter().map(|l| l.len()).sum::<usize>());
    let up = upward(&g);
    assert!(up.is_empty(), "imports of a higher layer: {up:?}");
    // The check sees an upward import when there is one.
    let mut planted = g.clone();
    planted
        .get_mut("model")
        .expect("model")
        .insert("engine".into());
    assert_eq!(upward(&planted), vec![("model".into(), "engine".into())]);
}

#[test]
fn the_cycle_finder_finds_a_planted_cycle() {
    let mut g = graph();
    g.get_mut("protocol")
        .expect("protocol")
        .insert("pipeline".into());
    let c = find_cycle(&g).expect("protocol -> pipeline -> ... -> protocol is a cycle");
    assert!(
        c.contains(&"protocol".to_string()) && c.contains(&"pipeline".to_string()),
        "{c:?}"
    );
}

/// `.cargo/config.toml` pins the property tests' seed, so CI checks the same
/// cases every run and a failure found there reproduces here.
/// The graph of the sub-modules of one top-level folder (`engine/agent`,
/// `engine/processes`, ...): `crate::TOP::SUB` references, and `super::SUB`
/// references from a file directly in the folder.
fn folder_graph(top: &str) -> BTreeMap<String, BTreeSet<String>> {
    let dir = root().join("src").join(top);
    let mut files = vec![];
    rust_files(&dir, &mut files);
    let sub_of = |f: &Path| -> Option<String> {
        let rel = f.strip_prefix(&dir).ok()?;
        let first = rel.components().next()?.as_os_str().to_str()?.to_string();
        let name = first.strip_suffix(".rs").unwrap_or(&first).to_string();
        (name != "mod" && !name.ends_with("_tests")).then_some(name)
    };
    let subs: BTreeSet<String> = files.iter().filter_map(|f| sub_of(f)).collect();
    let mut g: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for f in &files {
        let Some(from) = sub_of(f) else { continue };
        let direct = f.parent() == Some(dir.as_path());
        let text = code(&std::fs::read_to_string(f).expect("read source"));
        let deps = g.entry(from.clone()).or_default();
        let prefixes = [format!("crate::{top}::"), "super::".to_string()];
        for (k, prefix) in prefixes.iter().enumerate() {
            if k == 1 && !direct {
                continue;
            }
            for (i, _) in text.match_indices(prefix.as_str()) {
                let name: String = text[i + prefix.len()..]
                    .chars()
                    .take_while(|c| c.is_alphanumeric() || *c == '_')
                    .collect();
                if name != from && subs.contains(&name) {
                    deps.insert(name);
                }
            }
        }
    }
    g
}

#[test]
fn the_sub_modules_of_every_folder_import_each_other_without_cycles() {
    let folders: Vec<String> = std::fs::read_dir(root().join("src"))
        .expect("read src")
        .flatten()
        .filter(|e| e.path().is_dir())
        .map(|e| e.file_name().to_string_lossy().to_string())
        .collect();
    assert!(folders.contains(&"engine".to_string()));
    let engine = folder_graph("engine");
    assert!(
        engine["des"].contains("actions") && engine["threads"].contains("node"),
        "the scan sees imports inside a folder: {engine:?}"
    );
    for top in &folders {
        if let Some(c) = find_cycle(&folder_graph(top)) {
            panic!("import cycle inside src/{top}: {}", c.join(" -> "));
        }
    }
}

#[test]
fn no_module_imports_its_parent_wholesale_and_no_module_re_exports_a_glob() {
    let mut files = vec![];
    rust_files(&root().join("src"), &mut files);
    let mut bad = vec![];
    for f in &files {
        let name = f.file_name().and_then(|n| n.to_str()).unwrap_or("");
        if name.ends_with("_tests.rs") {
            continue;
        }
        let text = std::fs::read_to_string(f).expect("read source");
        // Test modules (`#[cfg(test)]` then a `mod`) may take their parent whole.
        let end = text
            .match_indices("#[cfg(test)]\n")
            .map(|(i, m)| i + m.len())
            .find(|&i| {
                let next = text[i..].trim_start();
                next.starts_with("mod ") || next.starts_with("pub(crate) mod ")
            })
            .unwrap_or(text.len());
        for line in text[..end].lines() {
            let l = line.trim_start();
            let glob = l.starts_with("use super::*;")
                || (l.starts_with("pub") && l.contains(" use ") && l.ends_with("::*;"));
            if glob {
                bad.push(format!("{}: {l}", f.display()));
            }
        }
    }
    assert!(
        bad.is_empty(),
        "wildcard imports outside tests:\n{}",
        bad.join("\n")
    );
}

#[test]
fn property_tests_draw_from_a_pinned_seed() {
    let seed = std::env::var("PROPTEST_RNG_SEED")
        .expect("PROPTEST_RNG_SEED is set by .cargo/config.toml [env]");
    assert!(seed.parse::<u64>().is_ok(), "not a u64: {seed:?}");
}
