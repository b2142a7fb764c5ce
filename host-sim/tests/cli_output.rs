//! Output errors are errors (issue 11, item 8): a tool that cannot write what it was asked to
//! exits non-zero, an output directory that cannot be one is refused before the work, and
//! `--out -` writes a single file to standard output.

use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

fn host_sim(args: &[&str]) -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_host-sim"));
    c.args(args);
    c
}

#[test]
fn json_to_a_full_device_fails() {
    let Ok(full) = std::fs::OpenOptions::new().write(true).open("/dev/full") else {
        eprintln!("no /dev/full on this machine: skipped");
        return;
    };
    let out = host_sim(&["run", "--scenario", "paper-10m", "--json", "--quiet"])
        .stdout(Stdio::from(full))
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("cannot write to standard output"), "{err}");
}

#[test]
fn an_output_directory_that_is_a_file_is_refused_before_the_run() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("results");
    std::fs::write(&file, "not a directory").unwrap();
    for flag in ["--out", "--record"] {
        let t0 = Instant::now();
        // The whole kilometre would take seconds: the refusal comes first.
        let out = host_sim(&[
            "run",
            "--scenario",
            "tunnel-1km",
            flag,
            file.to_str().unwrap(),
        ])
        .output()
        .unwrap();
        assert!(t0.elapsed() < Duration::from_secs(2), "{flag}: ran first");
        assert!(!out.status.success());
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains("is not a directory"), "{flag}: {err}");
    }
    let out = host_sim(&["run", "--scenario", "paper-10m", "--out", "-"])
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("several files"));
}

#[test]
fn a_single_file_goes_to_standard_output_with_out_dash() {
    let out = host_sim(&["export-map", "--scenario", "paper-10m", "--out", "-"])
        .output()
        .unwrap();
    assert!(out.status.success());
    assert_eq!(&out.stdout[..4], b"LCMP");
    let bytes = out.stdout;
    let mut map = Box::<loc_core::map::TunnelMap>::default();
    map.load_from_bytes(&bytes).unwrap();
    assert_eq!(map.landmarks().len(), 5);
}
