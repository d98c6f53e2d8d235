//! Gives the shared library an ELF soname, so executables linked against it record
//! `libdynaslice.so` (found through the loader's search path or an rpath) rather than whatever
//! path the linker was handed.

fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    if std::env::var("CARGO_CFG_TARGET_OS").as_deref() == Ok("linux") {
        println!("cargo:rustc-cdylib-link-arg=-Wl,-soname,libdynaslice.so");
    }
}
