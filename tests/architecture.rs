//! The crate tables of docs/architecture.md and README.md are made from the code: every package
//! of the workspace, the Python package and the lab (each its own workspace), its description
//! (Cargo.toml) and the workspace crates it depends on (`cargo metadata`). These tests fail when
//! a page and the code disagree; run them with `DYNASLICE_BLESS=1` to rewrite the tables. No
//! file circles either (below).

use std::path::{Path, PathBuf};
use std::process::Command;

const BEGIN: &str =
    "<!-- crate table: made by tests/architecture.rs (DYNASLICE_BLESS=1 rewrites it) -->";
const END: &str = "<!-- end of crate table -->";

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("tests/ is in the workspace")
        .to_path_buf()
}

/// The packages of the manifest at `manifest` (its workspace's members): name, description,
/// and the names of the path dependencies among `known` (normal and build, not dev).
fn packages(manifest: &Path) -> Vec<(String, String, Vec<String>)> {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let out = Command::new(cargo)
        .args([
            "metadata",
            "--format-version",
            "1",
            "--no-deps",
            "--offline",
            "--manifest-path",
        ])
        .arg(manifest)
        .output()
        .expect("cargo metadata runs");
    assert!(
        out.status.success(),
        "cargo metadata: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let meta: serde_json::Value = serde_json::from_slice(&out.stdout).expect("JSON");
    meta["packages"]
        .as_array()
        .expect("packages")
        .iter()
        .map(|p| {
            let deps = p["dependencies"]
                .as_array()
                .expect("dependencies")
                .iter()
                .filter(|d| d["path"].is_string() && d["kind"].as_str() != Some("dev"))
                .map(|d| d["name"].as_str().expect("name").to_string())
                .collect();
            (
                p["name"].as_str().expect("name").to_string(),
                p["description"].as_str().unwrap_or("").to_string(),
                deps,
            )
        })
        .collect()
}

/// The table as the page shows it: the library crates in dependency order, then the front
/// ends, the lab and the test crates, each row `| crate | what it is | depends on |`.
fn table() -> String {
    let root = root();
    let mut all = packages(&root.join("Cargo.toml"));
    all.extend(packages(&root.join("dynaslice-python/Cargo.toml")));
    all.extend(packages(&root.join("lab/Cargo.toml")));
    // Fewest workspace dependencies first, then by name: the layers read top-down.
    all.sort_by(|a, b| a.2.len().cmp(&b.2.len()).then(a.0.cmp(&b.0)));
    let mut s = String::from(
        "| crate | what it is (its Cargo.toml) | workspace crates it depends on |\n|---|---|---|\n",
    );
    for (name, description, mut deps) in all {
        deps.sort();
        let deps = if deps.is_empty() {
            "none".to_string()
        } else {
            deps.iter()
                .map(|d| format!("`{d}`"))
                .collect::<Vec<_>>()
                .join(", ")
        };
        s += &format!("| `{name}` | {description} | {deps} |\n");
    }
    s
}

/// Checks the crate table between the markers of the page at `relative` (from the root), or
/// rewrites it under `DYNASLICE_BLESS=1`.
fn check_table(relative: &str) {
    let page = root().join(relative);
    let text = std::fs::read_to_string(&page).expect(relative);
    let (Some(a), Some(b)) = (text.find(BEGIN), text.find(END)) else {
        panic!("{relative} has no crate-table markers ({BEGIN} … {END})");
    };
    let current = &text[a + BEGIN.len()..b];
    let wanted = format!("\n{}", table());
    if current != wanted {
        if std::env::var_os("DYNASLICE_BLESS").is_some() {
            let new = format!("{}{BEGIN}{wanted}{}", &text[..a], &text[b..]);
            std::fs::write(&page, new).expect(relative);
            return;
        }
        panic!(
            "{relative}'s crate table differs from the code; rerun with DYNASLICE_BLESS=1.\nwanted:\n{wanted}\nfound:\n{current}"
        );
    }
}

#[test]
fn the_architecture_page_lists_the_crates_as_they_are() {
    check_table("docs/architecture.md");
}

#[test]
fn the_readme_lists_the_crates_as_they_are() {
    check_table("README.md");
}

/// The module path of `file` under `src` (`a/b.rs` and `a/b/mod.rs` are `a::b`; `lib.rs` and
/// `main.rs` the root), as path segments.
fn module_of(src: &Path, file: &Path) -> Vec<String> {
    let rel = file
        .strip_prefix(src)
        .expect("under src")
        .with_extension("");
    let mut parts: Vec<String> = rel
        .iter()
        .map(|p| p.to_string_lossy().into_owned())
        .collect();
    if matches!(
        parts.last().map(String::as_str),
        Some("lib" | "main" | "mod")
    ) {
        parts.pop();
    }
    parts
}

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).expect("read_dir").flatten() {
        let path = entry.path();
        if path.is_dir() {
            rust_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

/// The files of `src` each file names through `crate::…` or `super::…` paths (its test modules'
/// paths too where `with_tests`): a path is the file of its longest prefix that is a module. A
/// parent module's edges to its own children (declaring and re-exporting them) are structure,
/// not use, and are left out.
fn file_edges(src: &Path, with_tests: bool) -> Vec<(Vec<String>, Vec<Vec<String>>)> {
    let mut files = Vec::new();
    rust_files(src, &mut files);
    let modules: Vec<(Vec<String>, PathBuf)> = files
        .iter()
        .map(|f| (module_of(src, f), f.clone()))
        .collect();
    let is_module = |m: &[String]| modules.iter().any(|(k, _)| k == m);
    let ident = |s: &str| -> Vec<String> {
        s.split(|c: char| !(c.is_alphanumeric() || c == '_'))
            .filter(|w| !w.is_empty())
            .map(str::to_string)
            .collect()
    };
    modules
        .iter()
        .map(|(module, path)| {
            let text = std::fs::read_to_string(path).expect("read");
            // Test modules may use anything, except in the core; the circles that matter are
            // the library's.
            let code = text
                .find("#[cfg(test)]")
                .into_iter()
                .chain(text.find("#[cfg(all(test"))
                .min()
                .filter(|_| !with_tests)
                .map_or(text.as_str(), |i| &text[..i]);
            let is_root = matches!(
                path.file_name().and_then(|n| n.to_str()),
                Some("lib.rs" | "main.rs" | "mod.rs")
            );
            let base: Vec<String> = if is_root {
                module.clone()
            } else {
                module[..module.len().saturating_sub(1)].to_vec()
            };
            let mut targets: Vec<Vec<String>> = Vec::new();
            for line in code
                .lines()
                .map(str::trim_start)
                .filter(|l| !l.starts_with("//"))
            {
                for (prefix, start) in [("crate::", Vec::new()), ("super::", base.clone())] {
                    for (at, _) in line.match_indices(prefix) {
                        let rest = &line[at + prefix.len()..];
                        // `crate::{a, b::c}` names several paths.
                        let heads: Vec<Vec<String>> = match rest.strip_prefix('{') {
                            Some(group) => group
                                .split('}')
                                .next()
                                .unwrap_or("")
                                .split(',')
                                .map(|item| ident(item.split(" as ").next().unwrap_or("")))
                                .collect(),
                            None => vec![ident(
                                rest.split(|c: char| {
                                    !(c.is_alphanumeric() || c == '_' || c == ':')
                                })
                                .next()
                                .unwrap_or(""),
                            )],
                        };
                        for head in heads {
                            let full: Vec<String> = start.iter().cloned().chain(head).collect();
                            let target = (0..=full.len())
                                .rev()
                                .map(|n| full[..n].to_vec())
                                .find(|m| is_module(m))
                                .unwrap_or_default();
                            let own_child = is_root && target.starts_with(module);
                            if target != *module && !own_child && !targets.contains(&target) {
                                targets.push(target);
                            }
                        }
                    }
                }
            }
            (module.clone(), targets)
        })
        .collect()
}

/// The groups of files of `src` that import each other in a circle (strongly connected
/// components of more than one file), test modules included where `with_tests`.
fn file_circles(src: &Path, with_tests: bool) -> Vec<Vec<String>> {
    let edges = file_edges(src, with_tests);
    let index = |m: &Vec<String>| edges.iter().position(|(k, _)| k == m);
    let n = edges.len();
    let adjacent: Vec<Vec<usize>> = edges
        .iter()
        .map(|(_, ts)| ts.iter().filter_map(index).collect())
        .collect();
    // Reachability by depth-first search from every file: small trees, no need for Tarjan.
    let reach: Vec<Vec<bool>> = (0..n)
        .map(|s| {
            let mut seen = vec![false; n];
            let mut stack = adjacent[s].clone();
            while let Some(v) = stack.pop() {
                if !std::mem::replace(&mut seen[v], true) {
                    stack.extend(&adjacent[v]);
                }
            }
            seen
        })
        .collect();
    let mut circles: Vec<Vec<String>> = Vec::new();
    let mut placed = vec![false; n];
    for a in 0..n {
        if placed[a] || !reach[a][a] {
            continue;
        }
        let group: Vec<usize> = (0..n).filter(|&b| reach[a][b] && reach[b][a]).collect();
        for &b in &group {
            placed[b] = true;
        }
        let mut names: Vec<String> = group
            .iter()
            .map(|&b| match edges[b].0.join("/") {
                s if s.is_empty() => "lib".to_string(),
                s => s,
            })
            .collect();
        names.sort();
        circles.push(names);
    }
    circles
}

#[test]
fn no_two_files_of_a_crate_import_each_other() {
    let root = root();
    let mut found = Vec::new();
    for entry in std::fs::read_dir(&root).expect("workspace").flatten() {
        let src = entry.path().join("src");
        if entry.path().join("Cargo.toml").is_file() && src.is_dir() {
            // The core, the crate every other builds on, keeps no circle even through its
            // tests.
            let with_tests = entry.file_name() == "dynaslice-core";
            for circle in file_circles(&src, with_tests) {
                found.push(format!(
                    "{}: {}",
                    entry.file_name().to_string_lossy(),
                    circle.join(" ↔ ")
                ));
            }
        }
    }
    assert!(
        found.is_empty(),
        "files that import each other in a circle (give the shared part a file of its own):\n{}",
        found.join("\n")
    );
}

#[test]
fn the_circle_check_finds_a_circle() {
    let dir = tempfile::tempdir().expect("tempdir");
    let src = dir.path().join("src");
    std::fs::create_dir_all(&src).unwrap();
    std::fs::write(
        src.join("lib.rs"),
        "mod a;\nmod b;\nmod c;\npub use a::A;\n",
    )
    .unwrap();
    std::fs::write(src.join("a.rs"), "use crate::b::B;\npub struct A;\n").unwrap();
    std::fs::write(src.join("b.rs"), "use super::{a::A, c};\npub struct B;\n").unwrap();
    std::fs::write(
        src.join("c.rs"),
        "pub struct C;\n#[cfg(test)]\nuse crate::a::A;\n",
    )
    .unwrap();
    assert_eq!(
        file_circles(&src, false),
        vec![vec!["a".to_string(), "b".to_string()]]
    );
    // With the test modules, c and a import each other too.
    assert_eq!(
        file_circles(&src, true),
        vec![vec!["a".to_string(), "b".to_string(), "c".to_string()]]
    );
}
