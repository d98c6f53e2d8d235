//! Puts memory.x where cortex-m-rt's link.x looks for it (the linker search path), and rebuilds
//! when it or the embedded models change.
use std::{env, fs, path::PathBuf};

fn main() {
    let out = PathBuf::from(env::var_os("OUT_DIR").expect("cargo sets OUT_DIR"));
    fs::copy("memory.x", out.join("memory.x")).expect("copy memory.x to OUT_DIR");
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rerun-if-changed=memory.x");
    println!("cargo:rerun-if-changed=../generated/model_f32.dsm");
    println!("cargo:rerun-if-changed=../generated/model_f16.dsm");
}
