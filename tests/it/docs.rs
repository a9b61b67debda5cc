//! The documentation a newcomer reads: README stays short, every relative
//! link of README, ARCHITECTURE.md, CHANGELOG.md and the book resolves (file
//! and anchor), and the book's Rust code is compiled as doctests.

use crate::util::root;
use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

/// The lines of a Markdown text outside fenced code blocks.
fn prose_lines(text: &str) -> Vec<&str> {
    let mut fenced = false;
    text.lines()
        .filter(|l| {
            if l.trim_start().starts_with("```") {
                fenced = !fenced;
                return false;
            }
            !fenced
        })
        .collect()
}

/// The anchors mdBook and GitHub give the headings of a Markdown file.
fn anchors(text: &str) -> BTreeSet<String> {
    let mut out = BTreeSet::new();
    for l in prose_lines(text) {
        if let Some(h) = l.strip_prefix('#') {
            let h = h.trim_start_matches('#').trim().to_lowercase();
            let a: String = h
                .chars()
                .filter(|c| c.is_alphanumeric() || *c == '-' || *c == '_' || *c == ' ')
                .map(|c| if c == ' ' { '-' } else { c })
                .collect();
            out.insert(a);
        }
    }
    out
}

/// The `[text](target)` links outside code blocks and code spans.
fn links(text: &str) -> Vec<String> {
    let mut out = Vec::new();
    for l in prose_lines(text) {
        // Drop code spans: a `[x](y)` inside backticks is not a link.
        let plain: String = l.split('`').step_by(2).collect::<Vec<_>>().join("");
        let mut rest = plain.as_str();
        while let Some(i) = rest.find("](") {
            let after = &rest[i + 2..];
            let Some(end) = after.find(')') else { break };
            out.push(after[..end].to_string());
            rest = &after[end..];
        }
    }
    out
}

fn markdown_files() -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> = [
        "README.md",
        "ARCHITECTURE.md",
        "CHANGELOG.md",
        "scenarios/README.md",
    ]
    .iter()
    .map(|f| root().join(f))
    .collect();
    let book = root().join("docs/src");
    let mut chapters: Vec<PathBuf> = std::fs::read_dir(&book)
        .expect("docs/src")
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|x| x == "md"))
        .collect();
    chapters.sort();
    files.extend(chapters);
    files
}

#[test]
fn every_relative_link_of_the_readme_and_the_book_resolves_to_a_file_and_anchor() {
    let mut broken = Vec::new();
    for f in markdown_files() {
        let text = std::fs::read_to_string(&f).expect("read markdown");
        for target in links(&text) {
            if target.starts_with("http://")
                || target.starts_with("https://")
                || target.starts_with("mailto:")
            {
                continue;
            }
            let (path, anchor) = target.split_once('#').unwrap_or((&target, ""));
            let dest = if path.is_empty() {
                f.clone()
            } else {
                f.parent().unwrap_or(Path::new(".")).join(path)
            };
            if !dest.exists() {
                broken.push(format!("{}: {target} (no such file)", f.display()));
                continue;
            }
            if !anchor.is_empty() && dest.extension().is_some_and(|x| x == "md") {
                let t = std::fs::read_to_string(&dest).expect("read link target");
                if !anchors(&t).contains(anchor) {
                    broken.push(format!("{}: {target} (no such heading)", f.display()));
                }
            }
        }
    }
    assert!(broken.is_empty(), "broken links:\n{}", broken.join("\n"));
}

#[test]
fn every_chapter_of_the_book_is_in_its_summary() {
    let summary = std::fs::read_to_string(root().join("docs/src/SUMMARY.md")).expect("SUMMARY.md");
    let listed: BTreeSet<String> = links(&summary).into_iter().collect();
    for f in markdown_files() {
        if f.parent() == Some(&root().join("docs/src")) {
            let name = f
                .file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_default();
            if name != "SUMMARY.md" {
                assert!(listed.contains(&name), "{name} is not in SUMMARY.md");
            }
        }
    }
}

#[test]
fn the_readme_is_at_most_150_lines() {
    let text = std::fs::read_to_string(root().join("README.md")).expect("README.md");
    let n = text.lines().count();
    assert!(
        n <= 150,
        "README.md has {n} lines: move detail into the book (docs/)"
    );
}

/// Rust code in the book is compiled only where lib.rs includes the chapter
/// as a doctest: a chapter with a `rust` block that is not included would
/// drift unseen.
#[test]
fn every_chapter_with_rust_code_is_compiled_as_a_doctest() {
    let lib = std::fs::read_to_string(root().join("src/lib.rs")).expect("lib.rs");
    for f in markdown_files() {
        let text = std::fs::read_to_string(&f).expect("read");
        if f.starts_with(root().join("docs/src")) && text.contains("```rust") {
            let name = f
                .file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_default();
            assert!(
                lib.contains(&format!("include_str!(\"../docs/src/{name}\")")),
                "{name} has Rust code that no doctest compiles"
            );
        }
    }
}
