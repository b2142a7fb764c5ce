//! The `sick-dump` binary on the real captures.

use std::process::Command;

use sick_captures::path as capture;
use sick_captures::*;

fn run(args: &[&str]) -> (String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_sick-dump"))
        .args(args)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    (
        String::from_utf8(out.stdout).unwrap(),
        String::from_utf8(out.stderr).unwrap(),
    )
}

#[test]
fn jsonl_has_one_object_per_scan_with_the_documented_keys() {
    let path = capture(LMS511_JSON);
    let (out, _) = run(&["--format", "jsonl", path.to_str().unwrap()]);
    let lines: Vec<&str> = out.lines().collect();
    assert_eq!(lines.len(), 174);
    let v: serde_json::Value = serde_json::from_str(lines[0]).unwrap();
    assert_eq!(v["serial_number"], 18_110_550);
    assert_eq!(v["scan_frequency_hz"], 25.0);
    assert!(v["scan_counter"].is_u64() && v["telegram_counter"].is_u64());
    let ch = &v["channels"][0];
    assert_eq!(ch["name"], "DIST1");
    assert_eq!(ch["count"], 1141);
    assert_eq!(ch["start_angle_deg"], -5.0);
    assert_eq!(ch["step_deg"], 0.1667);
    // The real LMS511 at 25 Hz / 54 kHz: the exact step scan-input uses, 1/6 degree.
    assert_eq!(v["measurement_frequency_hz"], 54_000.0);
    let exact = ch["beam_step_deg"].as_f64().unwrap();
    assert!((exact - 1.0 / 6.0).abs() < 1e-12, "{exact}");
    assert_eq!(ch["scale_factor"], 1.0);
    assert_eq!(ch["values"].as_array().unwrap().len(), 1141);
    assert_eq!(ch["values"][0], 0x0519);
    assert_eq!(v["channels"][1]["name"], "RSSI1");
}

#[test]
fn stats_and_table_on_every_capture() {
    for (name, scans) in [(LMS511_S2H, 174), (LMS111_JSON, 175), (TIM_PCAPNG, 16)] {
        let path = capture(name);
        let (out, _) = run(&["--stats", path.to_str().unwrap()]);
        assert!(
            out.contains(&format!("scans: {scans}  scan decode errors: 0")),
            "{out}"
        );
        assert!(
            out.contains("bad: 0 (checksum 0, length 0, oversize 0, truncated 0)"),
            "{out}"
        );
        assert!(out.lines().count() > scans, "one table row per telegram");
    }
    let (out, _) = run(&["--stats", "--quiet", capture(LMS511_JSON).to_str().unwrap()]);
    assert!(
        out.contains("answers by type: sAN 3, sEA 4, sRA 39, sSN 179, sWA 3"),
        "{out}"
    );
    assert!(
        out.contains("requests by type: sEN 4, sMN 3, sRN 39, sWN 3"),
        "{out}"
    );
}

#[test]
fn unreadable_file_is_a_clear_error() {
    let out = Command::new(env!("CARGO_BIN_EXE_sick-dump"))
        .arg("/nonexistent.bin")
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("cannot read recording"));
}
