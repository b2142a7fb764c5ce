//! `host-sim optimize` end to end (issue 9, items 2 and 3): a small GA through the command
//! line; the same search interrupted with Ctrl-C and resumed, and run as a cluster would
//! (pending work, shards, merge), giving the local run's result bit for bit.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

fn host_sim(args: &[&str]) -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_host-sim"));
    c.args(args);
    c
}

/// A small search: 12 individuals, at most 4 generations, 4 m of the paper's tunnel.
const SEARCH: [&str; 12] = [
    "--model",
    "p1",
    "--population",
    "12",
    "--generations",
    "4",
    "--length",
    "4",
    "--seed",
    "9",
    "--validation-seeds",
    "3",
];

fn optimize(out_flag: &str, dir: &Path, extra: &[&str]) -> std::process::Output {
    let mut args = vec!["optimize"];
    if out_flag == "--out" {
        args.extend(SEARCH);
    }
    args.extend([out_flag, dir.to_str().unwrap()]);
    args.extend(extra);
    host_sim(&args).output().unwrap()
}

fn summary(dir: &Path) -> serde_json::Value {
    let text = std::fs::read_to_string(dir.join("summary.json")).unwrap();
    let mut v: serde_json::Value = serde_json::from_str(&text).unwrap();
    // What may differ between sessions: wall time and the directory's name in the paths.
    v.as_object_mut().unwrap().remove("wall_time_s");
    v.as_object_mut().unwrap().remove("files");
    v
}

fn read(dir: &Path, file: &str) -> String {
    std::fs::read_to_string(dir.join(file)).unwrap()
}

fn reference(root: &Path) -> PathBuf {
    let dir = root.join("local");
    let out = optimize("--out", &dir, &["--json"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let j: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(j["model"], "P1");
    assert_eq!(j["best_genes"][2]["name"], "D");
    assert_eq!(j["best_genes"][2]["unit"], "m");
    assert!(j["evaluations"].as_u64().unwrap() >= 12);
    assert!(j["generations"].as_u64().unwrap() >= 1);
    assert!(j["best_fitness_mse"].as_f64().unwrap() > 0.0);
    for f in [
        "generations.csv",
        "population-000.csv",
        "convergence.png",
        "convergence.svg",
        "shapes.png",
        "shapes.svg",
        "spacing_histogram.png",
        "spacing_histogram.svg",
        "report.html",
        "summary.json",
    ] {
        assert!(dir.join(f).is_file(), "{f} missing");
    }
    let html = read(&dir, "report.html");
    assert!(html.contains("convergence.svg") && html.contains("Best genome"));
    dir
}

#[test]
fn interrupted_resumed_and_sharded_searches_equal_the_local_one() {
    let root = tempfile::tempdir().unwrap();
    let local = reference(root.path());

    // Ctrl-C once the first evaluations are on disk; --resume finishes the same search.
    let stopped = root.path().join("stopped");
    let mut args = vec!["optimize"];
    args.extend(SEARCH);
    args.extend(["--out", stopped.to_str().unwrap(), "--quiet"]);
    let mut child = host_sim(&args).stderr(Stdio::piped()).spawn().unwrap();
    let t0 = Instant::now();
    let evals = stopped.join("evaluations.csv");
    while std::fs::read_to_string(&evals).map_or(0, |t| t.lines().count()) < 4 {
        assert!(
            t0.elapsed() < Duration::from_secs(60),
            "no evaluation written"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
    let _ = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status();
    let status = child.wait().unwrap();
    let mut err = String::new();
    std::io::Read::read_to_string(child.stderr.as_mut().unwrap(), &mut err).unwrap();
    if status.success() {
        // The search ended before the signal arrived: nothing to resume, still equal.
        eprintln!("search finished before Ctrl-C");
    } else {
        assert!(err.contains("--resume"), "{err}");
        // A write cut by the interruption is read around, and evaluated again.
        let mut f = std::fs::OpenOptions::new()
            .append(true)
            .open(&evals)
            .unwrap();
        std::io::Write::write_all(&mut f, b"0.3,0.1").unwrap();
        let out = optimize("--resume", &stopped, &["--quiet"]);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
    assert_eq!(summary(&stopped), summary(&local));
    assert_eq!(
        read(&stopped, "generations.csv"),
        read(&local, "generations.csv")
    );

    // As a cluster runs it: pending work, two shards, merge, until the search finishes.
    let cluster = root.path().join("cluster");
    let out = optimize("--out", &cluster, &["--pending-only", "--json"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    for round in 0.. {
        assert!(round < 10, "the cluster loop does not end");
        if !cluster.join("pending.csv").exists() {
            break;
        }
        for shard in ["1/2", "0/2"] {
            let out = optimize("--resume", &cluster, &["--shard", shard]);
            assert!(
                out.status.success(),
                "{}",
                String::from_utf8_lossy(&out.stderr)
            );
        }
        let out = optimize("--resume", &cluster, &["--merge"]);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let out = optimize("--resume", &cluster, &["--pending-only", "--json"]);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
    assert_eq!(summary(&cluster), summary(&local));
    assert_eq!(
        read(&cluster, "generations.csv"),
        read(&local, "generations.csv")
    );
}

#[test]
fn bad_requests_are_refused_with_what_to_do() {
    let root = tempfile::tempdir().unwrap();
    let dir = root.path().join("s");
    let out = host_sim(&["optimize", "--model", "p7", "--out", dir.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("p1, p2"));
    let out = host_sim(&["optimize", "--resume", root.path().to_str().unwrap()])
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("not a search directory"));
    // A shard index from Slurm's variable must be below the count.
    let local = reference(root.path());
    let out = host_sim(&[
        "optimize",
        "--resume",
        local.to_str().unwrap(),
        "--shard-count",
        "2",
    ])
    .env("SLURM_ARRAY_TASK_ID", "5")
    .output()
    .unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("below the count"));
    // A second search into the same directory is refused.
    let out = optimize("--out", &local, &[]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("--resume"));
}

#[test]
fn table2_quick_writes_every_model_with_both_matchers() {
    let root = tempfile::tempdir().unwrap();
    let out = host_sim(&[
        "table2",
        "--quick",
        "--json",
        "--out",
        root.path().to_str().unwrap(),
    ])
    .output()
    .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let rows: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let rows = rows.as_array().unwrap();
    assert_eq!(rows.len(), 16);
    assert_eq!(rows[0]["summary"]["model"], "P1");
    assert_eq!(rows[0]["summary"]["matcher"], "icp");
    assert_eq!(rows[0]["paper_rms_m"], 0.042);
    assert_eq!(rows[15]["summary"]["model"], "F4");
    assert_eq!(rows[15]["summary"]["matcher"], "hausdorff");
    for r in rows {
        let v = &r["summary"]["validation_best"];
        assert_eq!(v["seeds"].as_array().unwrap().len(), 3);
        assert!(v["mean_position_rms_m"].as_f64().unwrap() > 0.0);
    }
    let md = read(root.path(), "table2.md");
    assert_eq!(md.lines().count(), 2 + 8, "{md}");
    assert!(md.contains("| F4 |"));
    for d in ["p1-icp", "p1-hausdorff", "f4-hausdorff"] {
        assert!(root.path().join(d).join("report.html").is_file(), "{d}");
    }
    // Run again: every search is finished, nothing is evaluated again.
    let again = host_sim(&[
        "table2",
        "--quick",
        "--json",
        "--out",
        root.path().to_str().unwrap(),
    ])
    .output()
    .unwrap();
    assert!(again.status.success());
    let rows2: serde_json::Value = serde_json::from_slice(&again.stdout).unwrap();
    for (a, b) in rows.iter().zip(rows2.as_array().unwrap()) {
        assert_eq!(a["summary"]["best_genes"], b["summary"]["best_genes"]);
        assert_eq!(a["summary"]["evaluations"], b["summary"]["evaluations"]);
    }
}
