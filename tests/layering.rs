//! The crate's layering (docs/architecture.md, "Layers"): every `crate::…` path in the
//! library and every `raysplat::…` path in the binary must point to a module of the same or a
//! lower rank in the table, and the modules (the stages of `pipeline` and the files of
//! `methods` counted one by one) must import each other without cycles.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// Ranks per top-level module, read from the "Layers" table of docs/architecture.md: rows
/// `| rank | `module` `module` … | … |`.
fn table() -> BTreeMap<String, u32> {
    let doc =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/architecture.md"))
            .expect("docs/architecture.md");
    let section = doc
        .split("\n## Layers")
        .nth(1)
        .expect("docs/architecture.md has a \"## Layers\" section");
    let mut ranks = BTreeMap::new();
    for line in section.lines().take_while(|l| !l.starts_with("## ")) {
        let cells: Vec<&str> = line.split('|').map(str::trim).collect();
        if cells.len() < 3 {
            continue;
        }
        let Ok(rank) = cells[1].parse::<u32>() else {
            continue;
        };
        for (i, name) in cells[2].split('`').enumerate() {
            if i % 2 == 1 {
                ranks.insert(name.to_string(), rank);
            }
        }
    }
    assert!(
        ranks.len() >= 6,
        "the Layers table lists too few modules: {ranks:?}"
    );
    ranks
}

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for e in std::fs::read_dir(dir)
        .expect("readable source folder")
        .flatten()
    {
        let p = e.path();
        if p.is_dir() {
            rust_files(&p, out);
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
}

/// The graph node of a module path (its components below the crate root): the stage or
/// method for `pipeline` and `methods`, the top-level module otherwise.
fn node(components: &[&str]) -> Option<String> {
    let top = *components.first()?;
    match (top, components.get(1)) {
        ("pipeline" | "methods", Some(sub)) => Some(format!("{top}::{sub}")),
        _ => Some(top.to_string()),
    }
}

/// The module components of a source file below src/ (`pipeline/photon/mod.rs` →
/// [pipeline, photon]); the binary's files (main.rs, cli/) count as `cli`.
fn file_module(rel: &Path) -> Vec<String> {
    let mut parts: Vec<String> = rel
        .iter()
        .map(|c| c.to_string_lossy().trim_end_matches(".rs").to_string())
        .collect();
    if parts.last().is_some_and(|l| l == "mod") {
        parts.pop();
    }
    if parts == ["main"] || parts.first().is_some_and(|p| p == "cli") {
        return vec!["cli".into()];
    }
    parts
}

/// Module paths named after `prefix` (`crate::` or `raysplat::`) on non-comment lines.
fn imports(source: &str, prefix: &str) -> Vec<Vec<String>> {
    let mut out = Vec::new();
    for line in source.lines() {
        let code = line.trim_start();
        if code.starts_with("//") {
            continue;
        }
        let mut rest = code;
        while let Some(i) = rest.find(prefix) {
            let before = rest[..i].chars().last();
            rest = &rest[i + prefix.len()..];
            if before.is_some_and(|c| c.is_alphanumeric() || c == '_') {
                continue;
            }
            // `crate::{a, b::c}` groups are not used in this crate; a path is the run of
            // identifiers joined by `::`.
            let path: Vec<String> = rest
                .split("::")
                .map(|s| {
                    s.chars()
                        .take_while(|c| c.is_alphanumeric() || *c == '_')
                        .collect::<String>()
                })
                .take_while(|s| !s.is_empty() && s.chars().next().is_some_and(|c| c.is_lowercase()))
                .collect();
            if !path.is_empty() {
                out.push(path);
            }
        }
    }
    out
}

#[test]
fn imports_follow_the_layers_and_have_no_cycles() {
    let ranks = table();
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    let mut edges: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    let mut violations = Vec::new();
    for f in &files {
        let rel = f.strip_prefix(&src).expect("under src");
        let module = file_module(rel);
        if module == ["lib"] {
            continue;
        }
        let parts: Vec<&str> = module.iter().map(String::as_str).collect();
        let from = node(&parts).expect("a module");
        let top = parts[0];
        let Some(&from_rank) = ranks.get(top) else {
            violations.push(format!(
                "{}: module `{top}` is not in the Layers table",
                rel.display()
            ));
            continue;
        };
        let source = std::fs::read_to_string(f).expect("readable source");
        let prefix = if top == "cli" {
            "raysplat::"
        } else {
            "crate::"
        };
        for path in imports(&source, prefix) {
            let parts: Vec<&str> = path.iter().map(String::as_str).collect();
            let Some(to) = node(&parts) else { continue };
            let Some(&to_rank) = ranks.get(parts[0]) else {
                violations.push(format!(
                    "{}: imports `{}`, which is not in the Layers table",
                    rel.display(),
                    parts[0]
                ));
                continue;
            };
            if to_rank > from_rank {
                violations.push(format!(
                    "{}: `{top}` (rank {from_rank}) imports `{}` (rank {to_rank})",
                    rel.display(),
                    parts.join("::")
                ));
            }
            if to != from {
                edges.entry(from.clone()).or_default().insert(to);
            }
        }
    }
    assert!(
        violations.is_empty(),
        "layering violations:\n{}",
        violations.join("\n")
    );
    if let Some(cycle) = find_cycle(&edges) {
        panic!("import cycle: {}", cycle.join(" → "));
    }
}

/// A cycle of the directed graph `edges`, by depth-first search.
fn find_cycle(edges: &BTreeMap<String, BTreeSet<String>>) -> Option<Vec<String>> {
    fn visit(
        n: &str,
        edges: &BTreeMap<String, BTreeSet<String>>,
        state: &mut BTreeMap<String, u8>,
        stack: &mut Vec<String>,
    ) -> Option<Vec<String>> {
        match state.get(n) {
            Some(2) => return None,
            Some(1) => {
                let i = stack.iter().position(|s| s == n).unwrap_or(0);
                let mut cycle = stack[i..].to_vec();
                cycle.push(n.to_string());
                return Some(cycle);
            }
            _ => {}
        }
        state.insert(n.to_string(), 1);
        stack.push(n.to_string());
        for m in edges.get(n).into_iter().flatten() {
            if let Some(c) = visit(m, edges, state, stack) {
                return Some(c);
            }
        }
        stack.pop();
        state.insert(n.to_string(), 2);
        None
    }
    let mut state = BTreeMap::new();
    edges
        .keys()
        .find_map(|n| visit(n, edges, &mut state, &mut Vec::new()))
}

/// The checker itself finds what it must: a path after `crate::`, not one in a comment or in
/// a longer identifier.
#[test]
fn the_import_reader_reads_paths() {
    let src = "use crate::pipeline::splat::{prepare, splat};\n// crate::app::App\nlet x = mycrate::methods::rs;\nlet y = crate::methods::Budget::Fixed;";
    assert_eq!(
        imports(src, "crate::"),
        vec![
            vec!["pipeline".to_string(), "splat".to_string()],
            vec!["methods".to_string()],
        ]
    );
    assert_eq!(node(&["pipeline", "splat"]), Some("pipeline::splat".into()));
    assert_eq!(node(&["scene", "load"]), Some("scene".into()));
}

/// The cycle search finds cache → radiance_map → cache, and nothing in a chain.
#[test]
fn a_cycle_is_found_and_a_chain_is_not() {
    let graph = |e: &[(&str, &str)]| {
        let mut g: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
        for (a, b) in e {
            g.entry(a.to_string()).or_default().insert(b.to_string());
        }
        g
    };
    let chain = graph(&[
        ("rs", "cache"),
        ("cache", "radiance_map"),
        ("rs", "radiance_map"),
    ]);
    assert_eq!(find_cycle(&chain), None);
    let cycle = graph(&[
        ("rs", "cache"),
        ("cache", "radiance_map"),
        ("radiance_map", "cache"),
    ]);
    assert_eq!(
        find_cycle(&cycle),
        Some(vec!["cache".into(), "radiance_map".into(), "cache".into()])
    );
}
