//! Build script: picks the board's memory layout and passes the link scripts.
//!
//! Link scripts go through `cargo:rustc-link-arg` (not `-bins`): with `-bins` other targets
//! link without `link.x` and come out empty, and QEMU locks up on them. `memory.x` is found
//! through the search path below, which cargo also hands to the crates that depend on this
//! one (the `testbench` binaries link with the same layout).

use std::env;
use std::fs;
use std::path::PathBuf;

fn main() {
    let out = PathBuf::from(env::var_os("OUT_DIR").expect("cargo sets OUT_DIR"));
    let memory = if env::var_os("CARGO_FEATURE_BOARD_NUCLEO_H743ZI").is_some() {
        "memory/nucleo-h743zi.x"
    } else if env::var_os("CARGO_FEATURE_BOARD_STM32F407").is_some() {
        "memory/stm32f407.x"
    } else {
        "memory/mps2-an386.x"
    };
    fs::copy(memory, out.join("memory.x")).expect("copy the board's memory.x into OUT_DIR");
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rerun-if-changed=memory");
    println!("cargo:rerun-if-changed=build.rs");
    println!("cargo:rustc-link-arg=-Tlink.x");
    println!("cargo:rustc-link-arg=-Tdefmt.x");
    println!("cargo:rustc-link-arg=--nmagic");
}
