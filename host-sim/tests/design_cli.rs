//! `host-sim design` end to end (issue 9, item 6): every file for the 1 km tunnel, the
//! template at 1:1, the schedule's spacings unique in every window, a surveyed centre line,
//! genes from a search, and a layout that cannot be made unique refused.

use std::path::Path;
use std::process::Command;

fn host_sim(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_host-sim"))
        .args(args)
        .output()
        .unwrap()
}

fn ok(out: &std::process::Output) -> serde_json::Value {
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap()
}

/// Spacings per wall from `schedule.csv`.
fn schedule_spacings(dir: &Path) -> (Vec<f64>, Vec<f64>, usize) {
    let text = std::fs::read_to_string(dir.join("schedule.csv")).unwrap();
    let mut rows = 0;
    let (mut left, mut right) = (Vec::new(), Vec::new());
    for line in text.lines().skip(1) {
        rows += 1;
        let f: Vec<&str> = line.split(',').collect();
        if let Ok(d) = f[3].parse::<f64>() {
            match f[1] {
                "left" => left.push(d),
                "right" => right.push(d),
                w => panic!("wall {w}"),
            }
        }
        assert_eq!(f[4], "1.200", "mounting height");
    }
    (left, right, rows)
}

#[test]
fn the_kilometre_design_writes_everything_and_its_spacings_identify_every_position() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path().to_str().unwrap();
    let r = ok(&host_sim(&[
        "design",
        "--scenario",
        "tunnel-1km",
        "--model",
        "p1",
        "--genes",
        "0.28,0.3,9",
        "--out",
        d,
        "--json",
    ]));
    for f in [
        "schedule.csv",
        "template.svg",
        "bom.csv",
        "map.postcard",
        "accuracy.csv",
        "accuracy.png",
        "accuracy.svg",
        "design.json",
    ] {
        assert!(dir.path().join(f).is_file(), "{f}");
    }
    // The template's outline measures W and H in millimetres, and prints in millimetres.
    let svg = std::fs::read_to_string(dir.path().join("template.svg")).unwrap();
    assert!(svg.contains(r#"mm" height=""#));
    let pts = host_sim::design::template_svg::outline_mm(&svg).unwrap();
    let span = |k: usize| {
        let v = pts.iter().map(|p| if k == 0 { p.0 } else { p.1 });
        v.clone().fold(f64::MIN, f64::max) - v.fold(f64::MAX, f64::min)
    };
    assert!((span(0) - 280.0).abs() < 0.01, "W {}", span(0));
    assert!((span(1) - 300.0).abs() < 0.01, "H {}", span(1));
    // The schedule: every landmark, spacings in §4.4's interval, every window unique.
    let (left, right, rows) = schedule_spacings(dir.path());
    assert_eq!(
        rows as u64,
        r["bill_of_materials"]["count"].as_u64().unwrap()
    );
    assert!(rows > 200, "{rows}");
    for (d, k) in [
        (&left, &r["shortest_unique_window"][0]),
        (&right, &r["shortest_unique_window"][1]),
    ] {
        assert!(d.iter().all(|&x| (8.374..=9.626).contains(&x)), "{d:?}");
        let k = k.as_u64().unwrap() as usize;
        assert!((1..=3).contains(&k));
        assert_eq!(host_sim::design::spacing::ambiguous_pair(d, k, 0.05), None);
    }
    // The map file loads in loc-core.
    let bytes = std::fs::read(dir.path().join("map.postcard")).unwrap();
    let mut map = Box::new(loc_core::map::TunnelMap::new());
    map.load_from_bytes(&bytes).unwrap();
    assert_eq!(map.landmarks().len(), rows);
    // The predicted accuracy covers the drive and meets a 10 mm target.
    let acc = std::fs::read_to_string(dir.path().join("accuracy.csv")).unwrap();
    assert!(acc.lines().count() > 900);
    assert!(r["worst_along_sd_m"].as_f64().unwrap() < 0.01);
    assert_eq!(r["stretches_above_target"].as_array().unwrap().len(), 0);
    // A tight target lists the stretches that miss it.
    let tight = tempfile::tempdir().unwrap();
    let r2 = ok(&host_sim(&[
        "design",
        "--scenario",
        "tunnel-1km",
        "--model",
        "p1",
        "--genes",
        "0.28,0.3,9",
        "--out",
        tight.path().to_str().unwrap(),
        "--json",
        "--target-mm",
        "1.5",
    ]));
    assert!(!r2["stretches_above_target"].as_array().unwrap().is_empty());
}

#[test]
fn surveyed_centre_lines_searches_and_impossible_layouts() {
    let root = tempfile::tempdir().unwrap();
    let csv = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenarios/s-bend-400m.csv");
    let out = root.path().join("csv");
    let r = ok(&host_sim(&[
        "design",
        "--centerline",
        csv.to_str().unwrap(),
        "--width",
        "5",
        "--model",
        "f4",
        "--out",
        out.to_str().unwrap(),
        "--json",
    ]));
    assert!(r["tunnel_length_m"].as_f64().unwrap() > 300.0);
    assert_eq!(r["model"], "F4");
    // Genes from a finished search.
    let search = root.path().join("search");
    let s = host_sim(&[
        "optimize",
        "--model",
        "p2",
        "--population",
        "6",
        "--generations",
        "2",
        "--length",
        "3",
        "--validation-seeds",
        "2",
        "--quiet",
        "--out",
        search.to_str().unwrap(),
    ]);
    assert!(s.status.success(), "{}", String::from_utf8_lossy(&s.stderr));
    let best: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(search.join("summary.json")).unwrap())
            .unwrap();
    let out = root.path().join("from-search");
    let r = ok(&host_sim(&[
        "design",
        "--scenario",
        "demo-200m",
        "--from-search",
        search.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--json",
    ]));
    assert_eq!(r["model"], "P2");
    let g0 = best["best_genes"][0]["value"].as_f64().unwrap();
    assert!((r["genes"][0].as_f64().unwrap() - g0).abs() < 1e-6);
    // One spacing cannot tell 100 positions apart at 600 mm: refused, nothing written.
    let out = root.path().join("refused");
    let e = host_sim(&[
        "design",
        "--scenario",
        "tunnel-1km",
        "--model",
        "p1",
        "--window",
        "1",
        "--spacing-tolerance-mm",
        "600",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(!e.status.success());
    let msg = String::from_utf8_lossy(&e.stderr);
    assert!(msg.contains("--window"), "{msg}");
    assert!(!out.join("schedule.csv").exists());
}
