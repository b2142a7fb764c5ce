#!/usr/bin/env python3
"""The peer comparison: loc-core (`host-sim replay`) beside KISS-ICP's and small_gicp's
registrations run as scan-to-map localisers on the same recordings, scored by the same
metrics (`host-sim replay --estimates`). Run it through compare.sh (which makes the Python
environment); see the README's "Accuracy against the peers".

Work files go under --work (default target/peers): recordings, their scans as JSON lines,
their maps as JSON, each peer's estimates (kept: a second run only re-runs what changed; the
core is always re-run, it takes seconds).
"""

import argparse
import concurrent.futures as cf
import hashlib
import itertools
import json
import os
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
HERE = Path(__file__).resolve().parent
BIN = ROOT / "target" / "release"

# (name, host-sim run arguments) of each drive; every one with seeds 1-3, with the
# scenario's landmarks and with none.
DRIVES = [
    ("paper-10m", ["--scenario", "paper-10m"]),
    ("tunnel-1km-200m", ["--scenario", "tunnel-1km", "--length", "200"]),
    ("s-bend-400m", [str(ROOT / "host-sim" / "scenarios" / "s-bend-400m.toml")]),
]
SEEDS = [1, 2, 3]
LANDMARKS = ["scenario", "none"]
# The peers are tuned on the start of each drive (seed 1, landmarks): `--length` of each.
TUNING_LENGTH_M = {"paper-10m": None, "tunnel-1km-200m": 60, "s-bend-400m": 30}

# The peers' settings as committed (chosen by `compare.sh --tune`; README says why).
CONFIGS = json.loads((HERE / "configs.json").read_text())
# `--sweep`: the drives recorded with the scanner's sweep (each beam from where the vehicle
# was when the mirror passed it), the core de-skewing, every peer de-skewed at the constant
# velocity of its own last two estimates (peers.py); kept in their own work directory.
SWEEP = []


def log(msg):
    print(msg, file=sys.stderr, flush=True)


def run(cmd, **kw):
    r = subprocess.run(cmd, capture_output=True, text=True, **kw)
    if r.returncode != 0:
        raise RuntimeError(f"{' '.join(map(str, cmd))} failed ({r.returncode}):\n{r.stderr[-2000:]}")
    return r.stdout


def prepare(work, drive, args, seed, landmarks):
    """Records the drive (once) and writes its scans (sick-dump) and map (export-map)."""
    name = f"{drive}-{'lm' if landmarks == 'scenario' else 'none'}-s{seed}"
    d = work / "recordings" / name
    if not (d / "README.txt").exists():
        log(f"recording {name}")
        extra = [] if landmarks == "scenario" else ["--landmarks", "none"]
        tmp = work / "recordings" / (name + ".partial")
        run(["rm", "-rf", str(tmp)])
        run([BIN / "host-sim", "run", *args, *extra, *SWEEP, "--seed", str(seed), "--record", str(tmp), "--quiet", "--json"])
        tmp.rename(d)
    scans = d.parent / (name + ".scans.jsonl")
    if not scans.exists():
        scans.write_text(run([BIN / "sick-dump", "--format", "jsonl", str(d / "scanner.colab.bin")]))
    # The map as host-sim now makes it, every run (a second or two): the core replays the
    # recording's map.postcard, the peers read the JSON, and both must be today's.
    mp = d.parent / (name + ".map.json")
    run([BIN / "host-sim", "export-map", str(d / "scenario.toml"), "--format", "json", "--out", str(mp)])
    run([BIN / "host-sim", "export-map", str(d / "scenario.toml"), "--out", str(d / "map.postcard")])
    # The same recording started at the true pose (for the "true start" rows).
    ip = d.parent / (name + ".initial_true.csv")
    if not ip.exists():
        truth = (d / "ground_truth.csv").read_text().splitlines()
        hdr = truth[0].split(",")
        first = dict(zip(hdr, truth[1].split(",")))
        init = (d / "initial_pose.csv").read_text().splitlines()
        ihdr, irow = init[0].split(","), init[1].split(",")
        given = dict(zip(ihdr, irow))
        ip.write_text(
            "x_m,y_m,theta_rad,sigma_xy_m,sigma_theta_rad\n"
            f"{first['x_m']},{first['y_m']},{first['theta_rad']},{given['sigma_xy_m']},{given['sigma_theta_rad']}\n"
        )
    return name, d, scans, mp, ip


def score(rec, extra):
    out = run([BIN / "host-sim", "replay", str(rec), "--json", *extra])
    m = json.loads(out)
    return {
        "position_rms_mm": m["position_rms_m"] * 1e3,
        "along_rms_mm": m["along_rms_m"] * 1e3,
        "across_rms_mm": m["across_rms_m"] * 1e3,
        "heading_rms_mrad": m["heading_rms_rad"] * 1e3,
        "max_error_mm": m["max_position_error_m"] * 1e3,
        "ms_per_scan": m["mean_us_per_scan"] / 1e3,
        "odometry_along_rms_mm": m["odometry_along_rms_m"] * 1e3,
        "scans": m["scans"],
    }


def config_key(peer, cfg, start, inputs=()):
    """The name a peer's estimates are kept under: its settings, its start and the contents
    of its inputs (a map or scans made anew by a changed host-sim are a new run)."""
    h = hashlib.sha1(json.dumps([peer, cfg, start], sort_keys=True).encode())
    for path in inputs:
        h.update(Path(path).read_bytes())
    return f"{peer}-{start}-{h.hexdigest()[:10]}"


def peer_estimates(work, name, rec, scans, mp, peer, cfg, start):
    """Runs one peer once (estimates kept by recording, peer, settings, start, map and scans)."""
    out = work / "estimates" / name / (config_key(peer, cfg, start, (mp, scans)) + ".csv")
    if not out.exists():
        out.parent.mkdir(parents=True, exist_ok=True)
        tmp = out.with_suffix(".partial")
        cmd = [sys.executable, HERE / "peers.py", "--recording", rec, "--scans", scans, "--map", mp,
               "--peer", peer, "--config", json.dumps(cfg), "--start", start, "--out", tmp]
        t = time.time()
        run([str(c) for c in cmd])
        tmp.rename(out)
        log(f"  {name}: {peer} {cfg.get('type', '')} from {start} in {time.time() - t:.0f} s")
    return out


def peer_list():
    """(label, peer module, settings) of each peer row."""
    return [(label, c["peer"], c["settings"]) for label, c in CONFIGS.items()]


def compare(work, jobs, drives, seeds, landmarks=LANDMARKS):
    prepared = []
    # Seed by seed, so that an interrupted comparison has whole drives done (estimates are
    # kept; a rerun only runs what is missing).
    for seed, (drive, args), lm in itertools.product(seeds, drives, landmarks):
        prepared.append(prepare(work, drive, args, seed, lm))
    results = {}
    with cf.ThreadPoolExecutor(max_workers=jobs) as pool:
        futs = {}
        for name, rec, scans, mp, ip in prepared:
            for label, peer, cfg in peer_list():
                for start in ["initial", "truth"]:
                    f = pool.submit(peer_estimates, work, name, rec, scans, mp, peer, cfg, start)
                    futs[f] = (name, rec, label, start)
        for f in cf.as_completed(futs):
            name, rec, label, start = futs[f]
            results[(name, label, start)] = score(rec, ["--estimates", str(f.result())])
    for name, rec, scans, mp, ip in prepared:
        results[(name, "loc-core", "initial")] = score(rec, [])
        results[(name, "loc-core", "truth")] = score(rec, ["--initial-pose", str(ip)])
    return [p[0] for p in prepared], results


def table(names, results):
    labels = ["loc-core"] + [p[0] for p in peer_list()]
    lines = [
        "| recording | localiser | start | position RMS mm | along mm | across mm | heading mrad | max mm | ms/scan |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    verdicts = []
    for name in names:
        for start in ["initial", "truth"]:
            for label in labels:
                r = results.get((name, label, start))
                if r is None:
                    continue
                lines.append(
                    f"| {name} | {label} | {start} | {r['position_rms_mm']:.2f} | {r['along_rms_mm']:.2f} | "
                    f"{r['across_rms_mm']:.2f} | {r['heading_rms_mrad']:.3f} | {r['max_error_mm']:.1f} | {r['ms_per_scan']:.3f} |"
                )
        core = results[(name, "loc-core", "initial")]
        # Every peer from both starts (keyed by both: keyed by the peer alone, the truth
        # start's result replaced the initial start's, and a peer that did better from the
        # recording's initial pose was not counted).
        peers = {
            (l, s): results[(name, l, s)]
            for l in labels[1:]
            for s in ["initial", "truth"]
            if (name, l, s) in results
        }
        if not peers:
            continue
        best_pos = min(r["position_rms_mm"] for r in peers.values())
        best_head = min(r["heading_rms_mrad"] for r in peers.values())
        best_across = min(r["across_rms_mm"] for r in peers.values())
        row = {
            "recording": name,
            "core_position_mm": core["position_rms_mm"],
            "best_peer_position_mm": best_pos,
            "ratio": core["position_rms_mm"] / best_pos,
            "core_heading_mrad": core["heading_rms_mrad"],
            "best_peer_heading_mrad": best_head,
            "core_across_mm": core["across_rms_mm"],
            "best_peer_across_mm": best_across,
            "core_along_mm": core["along_rms_mm"],
            "odometry_along_mm": core["odometry_along_rms_mm"],
        }
        verdicts.append(row)
    summary = [
        "",
        "| recording | core position mm | best peer mm | ratio (aim <= 0.8) | core heading mrad | best peer mrad | core across mm | best peer across mm | core along mm | odometry along mm |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for v in verdicts:
        summary.append(
            f"| {v['recording']} | {v['core_position_mm']:.2f} | {v['best_peer_position_mm']:.2f} | {v['ratio']:.2f} | "
            f"{v['core_heading_mrad']:.3f} | {v['best_peer_heading_mrad']:.3f} | {v['core_across_mm']:.2f} | "
            f"{v['best_peer_across_mm']:.2f} | {v['core_along_mm']:.1f} | {v['odometry_along_mm']:.1f} |"
        )
    return "\n".join(lines + summary), verdicts


def tune(work, jobs):
    """A grid over each peer's main settings on the start of each drive (seed 1, with
    landmarks; TUNING_LENGTH_M), from the initial pose: the setting with the lowest mean
    position RMS is the one to commit in configs.json."""
    grids = json.loads((HERE / "tuning.json").read_text())
    prepared = []
    for d, a in DRIVES:
        n = TUNING_LENGTH_M[d]
        if n is None:
            prepared.append(prepare(work, d, a, 1, "scenario"))
        else:
            args = [x for x in a]
            if "--length" in args:
                i = args.index("--length")
                del args[i : i + 2]
            prepared.append(prepare(work, f"tune-{d}-{n}m", args + ["--length", str(n)], 1, "scenario"))
    scored = {}
    with cf.ThreadPoolExecutor(max_workers=jobs) as pool:
        futs = {}
        for label, g in grids.items():
            keys = sorted(g["grid"])
            for values in itertools.product(*(g["grid"][k] for k in keys)):
                cfg = dict(g["base"], **dict(zip(keys, values)))
                for name, rec, scans, mp, ip in prepared:
                    f = pool.submit(peer_estimates, work, name, rec, scans, mp, g["peer"], cfg, "initial")
                    futs[f] = (label, json.dumps(cfg, sort_keys=True), name, rec)
        for f in cf.as_completed(futs):
            label, cfg, name, rec = futs[f]
            scored.setdefault((label, cfg), {})[name] = score(rec, ["--estimates", str(f.result())])["position_rms_mm"]
    names = [p[0] for p in prepared]
    print("position RMS (mm) on " + " / ".join(names) + ", from the initial pose:")
    core = [score(p[1], [])["position_rms_mm"] for p in prepared]
    print("loc-core: " + " / ".join(f"{r:.2f}" for r in core))
    best = {}
    for (label, cfg), by_name in sorted(scored.items()):
        rms = [by_name[n] for n in names]
        mean = sum(rms) / len(rms)
        print(f"{label}: {cfg} -> " + " / ".join(f"{r:.2f}" for r in rms) + f" mm (mean {mean:.2f})")
        if label not in best or mean < best[label][0]:
            best[label] = (mean, cfg)
    print("\nbest settings:")
    for label, (mean, cfg) in best.items():
        print(f"  {label}: mean {mean:.2f} mm: {cfg}")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--work", default=None, help="work directory (default target/peers, target/peers-sweep with --sweep)")
    ap.add_argument("--sweep", action="store_true", help="the drives with the scanner's sweep, de-skewed")
    ap.add_argument("--jobs", type=int, default=max(1, (os.cpu_count() or 2)))
    ap.add_argument("--quick", action="store_true", help="paper-10m seed 1 only")
    ap.add_argument("--seeds", type=int, nargs="+", default=SEEDS, help="seeds to run (default 1 2 3)")
    ap.add_argument("--drives", nargs="+", default=[d for d, _ in DRIVES], help="drives to run (default all)")
    ap.add_argument("--landmarks", nargs="+", choices=LANDMARKS, default=LANDMARKS,
                    help="with the scenario's landmarks, without, or both (default)")
    ap.add_argument("--tune", action="store_true", help="grid over the peers' settings (tuning.json)")
    ap.add_argument("--json", help="also write the results here")
    a = ap.parse_args()
    if a.sweep:
        SWEEP.append("--sweep")
    work = Path(a.work or ROOT / "target" / ("peers-sweep" if a.sweep else "peers"))
    work.mkdir(parents=True, exist_ok=True)
    if a.tune:
        tune(work, a.jobs)
        return
    chosen = [d for d in DRIVES if d[0] in a.drives]
    drives, seeds = (DRIVES[:1], [1]) if a.quick else (chosen, a.seeds)
    names, results = compare(work, a.jobs, drives, seeds, LANDMARKS if a.quick else a.landmarks)
    text, verdicts = table(names, results)
    print(text)
    if a.json:
        Path(a.json).write_text(json.dumps(
            {"rows": [dict(recording=n, localiser=l, start=s, **r) for (n, l, s), r in sorted(results.items())],
             "verdicts": verdicts}, indent=1))


if __name__ == "__main__":
    main()
