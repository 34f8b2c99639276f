//! Puts `memory.x` on the linker search path and adds the cortex-m-rt and defmt linker
//! scripts to the test and binary links (not the library's).
use std::{env, fs, path::PathBuf};

fn main() {
    let out = PathBuf::from(env::var_os("OUT_DIR").expect("OUT_DIR"));
    fs::write(out.join("memory.x"), include_bytes!("memory.x")).expect("write memory.x");
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rerun-if-changed=memory.x");
    println!("cargo:rerun-if-changed=build.rs");
    for kind in ["tests", "bins"] {
        println!("cargo:rustc-link-arg-{kind}=-Tlink.x");
    }
    // defmt's section layout: the suite logs with defmt; the bins do not (a footprint image
    // carries no logging), but `-Tdefmt.x` is harmless when no defmt symbol is linked.
    println!("cargo:rustc-link-arg-tests=-Tdefmt.x");
    println!("cargo:rustc-link-arg-bins=-Tdefmt.x");
}
