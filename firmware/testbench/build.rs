//! Build script: the link scripts of the binaries (the product crate's build script puts
//! the board's `memory.x` on the search path), and the "recording" of the synthetic scans,
//! map and start pose the benchmark and the self-tests replay (`build/record.rs`).

use std::env;
use std::path::PathBuf;

#[path = "build/record.rs"]
mod record;

fn main() {
    let out = PathBuf::from(env::var_os("OUT_DIR").expect("cargo sets OUT_DIR"));
    println!("cargo:rerun-if-changed=build");
    println!("cargo:rerun-if-changed=build.rs");
    println!("cargo:rustc-link-arg=-Tlink.x");
    println!("cargo:rustc-link-arg=-Tdefmt.x");
    println!("cargo:rustc-link-arg=--nmagic");
    record::write_recordings(&out);
}
