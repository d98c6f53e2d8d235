//! docs/architecture.md's crate table is made from the code: every package of the workspace
//! and the Python package, its description (Cargo.toml) and the workspace crates it depends on
//! (`cargo metadata`). This test fails when the page and the code disagree; run it with
//! `DYNASLICE_BLESS=1` to rewrite the table.

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

#[test]
fn the_architecture_page_lists_the_crates_as_they_are() {
    let page = root().join("docs/architecture.md");
    let text = std::fs::read_to_string(&page).expect("docs/architecture.md");
    let (Some(a), Some(b)) = (text.find(BEGIN), text.find(END)) else {
        panic!("docs/architecture.md has no crate-table markers ({BEGIN} … {END})");
    };
    let current = &text[a + BEGIN.len()..b];
    let wanted = format!("\n{}", table());
    if current != wanted {
        if std::env::var_os("DYNASLICE_BLESS").is_some() {
            let new = format!("{}{BEGIN}{wanted}{}", &text[..a], &text[b..]);
            std::fs::write(&page, new).expect("write docs/architecture.md");
            return;
        }
        panic!(
            "docs/architecture.md's crate table differs from the code; rerun with DYNASLICE_BLESS=1.\nwanted:\n{wanted}\nfound:\n{current}"
        );
    }
}
