//! Headless Chromium for the tests that open a page as a user's browser does (`dynaslice
//! report`): found or skipped with a notice, and started isolated (a fresh profile, none of
//! Chromium's network services, which this machine's closed network refuses).

use std::path::Path;
use std::process::{Command, Output};

/// Headless Chromium, or `None` (with a notice) where it is not installed; CI, which installs
/// it, sets DYNASLICE_REQUIRE_PYTHON, and there a missing browser fails the test.
pub fn chromium() -> Option<&'static str> {
    let found = ["chromium", "chromium-browser"].into_iter().find(|c| {
        Command::new(c)
            .arg("--version")
            .output()
            .is_ok_and(|o| o.status.success())
    });
    if found.is_none() {
        assert!(
            std::env::var_os("DYNASLICE_REQUIRE_PYTHON").is_none(),
            "chromium is not installed but DYNASLICE_REQUIRE_PYTHON is set"
        );
        println!("SKIPPED: chromium is not installed (apt-get install chromium)");
    }
    found
}

/// `browser` headless on `page` with software WebGL (SwiftShader, ANGLE's software backend,
/// opted into explicitly: Chromium 156 and later log a deprecation notice to the page's console
/// when it falls back to it by itself), a 1200 × 900 window and `args`.
pub fn browse_webgl(browser: &str, page: &Path, args: &[&str]) -> Output {
    let mut all = vec![
        "--use-angle=swiftshader",
        "--enable-unsafe-swiftshader",
        "--window-size=1200,900",
    ];
    all.extend_from_slice(args);
    browse(browser, page, &all)
}

/// `browser` headless on `page` with `args` (e.g. `--dump-dom`, a window size, software
/// WebGL), isolated: a fresh profile, no network services; its console messages go to stderr.
pub fn browse(browser: &str, page: &Path, args: &[&str]) -> Output {
    let profile = tempfile::tempdir().unwrap();
    let url = format!("file://{}", page.canonicalize().unwrap().display());
    Command::new(browser)
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-quic",
            "--no-first-run",
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
            "--enable-logging=stderr",
            "--v=0",
        ])
        .arg(format!("--user-data-dir={}", profile.path().display()))
        .args(args)
        .arg(url)
        .output()
        .unwrap()
}
