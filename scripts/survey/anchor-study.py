#!/usr/bin/env python3
"""How many surveyed anchors a survey without the design prior needs, with and without a gyro.

Records `tunnel-1km` (P1, landmarks installed 3 cm (1σ) off their marks) twice — track
odometry alone, and with the simulator's STIM300-like yaw-rate gyro (`--gyro`) — then surveys
each recording with the design prior (the default) and with `--no-design-prior` tied to
anchors: true as-built landmark centres every SPACING metres from landmark 3, or two anchors
at the tunnel's ends. Each map is scored against the true as-built map (landmark RMS, the
survey's own `against_truth`) and localised against by `host-sim replay` (position RMS).

    python3 scripts/survey/anchor-study.py [--seed 7] [--work DIR]

Needs `cargo build --release -p host-sim`; about two minutes on a 2-core machine.
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
HOST_SIM = os.path.join(ROOT, "target", "release", "host-sim")


def host_sim(*args, capture=True):
    r = subprocess.run([HOST_SIM, *args], capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit(f"host-sim {' '.join(args)} failed:\n{r.stderr[-2000:]}")
    return r.stdout


def centre(landmark):
    p = landmark["polyline"]
    return ((p[0][0] + p[-1][0]) / 2, (p[0][1] + p[-1][1]) / 2)


def anchors(landmarks, spacing_m):
    """Landmark indices nearest to every spacing_m from landmark 3 (the first surveyed)."""
    first, last = landmarks[3]["s_m"], landmarks[-1]["s_m"]
    idx, s = [], first
    while s <= last + 1.0:
        i = min(range(1, len(landmarks)), key=lambda i: abs(landmarks[i]["s_m"] - s))
        if i not in idx:
            idx.append(i)
        s += spacing_m
    return idx


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seed", type=int, default=7)
    ap.add_argument("--work", help="keep the recordings and maps here (default: a temporary folder)")
    a = ap.parse_args()
    if not os.path.exists(HOST_SIM):
        sys.exit("build host-sim first: cargo build --release -p host-sim")
    work = a.work or tempfile.mkdtemp(prefix="anchor-study-")
    os.makedirs(work, exist_ok=True)
    common = ["--scenario", "tunnel-1km", "--seed", str(a.seed), "--install-sd", "0.03"]
    as_built = os.path.join(work, "as_built.json")
    host_sim("export-map", *common, "--as-built", "--format", "json", "--out", as_built)
    landmarks = json.load(open(as_built))["landmarks"]
    setups = [("design prior (default)", None)]
    for spacing in (100.0, 250.0):
        setups.append((f"anchors every {spacing:.0f} m", anchors(landmarks, spacing)))
    # Two anchors at the tunnel's ends, and two 370 m apart near its start.
    setups.append(("2 anchors at the ends", anchors(landmarks, landmarks[-2]["s_m"] - landmarks[3]["s_m"])))
    setups.append(("2 anchors, 31 and 405 m", [3, 150]))
    rows = []
    for odometry, extra in (("tracks", []), ("tracks + gyro", ["--gyro"])):
        rec = os.path.join(work, "rec-gyro" if extra else "rec")
        print(f"recording tunnel-1km ({odometry}) into {rec}", file=sys.stderr)
        host_sim("run", *common, *extra, "--record", rec, "--quiet")
        for name, idx in setups:
            out = os.path.join(work, f"{os.path.basename(rec)}-{len(rows)}")
            args = ["survey", rec, "--out", out, "--quiet"]
            if idx is not None:
                args.append("--no-design-prior")
                for i in idx:
                    x, y = centre(landmarks[i])
                    args += ["--anchor", f"{i},{x:.4f},{y:.4f}"]
            host_sim(*args)
            t = json.load(open(os.path.join(out, "survey.json")))["against_truth"]["surveyed"]
            replay = json.loads(host_sim("replay", rec, "--map", os.path.join(out, "survey.postcard"), "--json"))
            rows.append((odometry, name, len(idx) if idx else 0, t, replay["position_rms_m"]))
            print(f"  {name}: {t['rms_m'] * 1e3:.1f} mm", file=sys.stderr)
        truth = json.loads(host_sim("replay", rec, "--map", os.path.join(rec, "as_built.postcard"), "--json"))
        design = json.loads(host_sim("replay", rec, "--json"))
        rows.append((odometry, "true as-built map", 0, None, truth["position_rms_m"]))
        rows.append((odometry, "design map", 0, None, design["position_rms_m"]))
    print("| odometry | gauge | anchors | landmarks vs truth RMS (along / across) | max | `replay` position RMS |")
    print("|---|---|---|---|---|---|")
    for odometry, name, n, t, replay in rows:
        if t is None:
            print(f"| {odometry} | {name} | | | | {replay * 1e3:.2f} mm |")
        else:
            print(
                f"| {odometry} | {name} | {n or ''} | {t['rms_m'] * 1e3:.1f} mm "
                f"({t['rms_along_m'] * 1e3:.1f} / {t['rms_across_m'] * 1e3:.1f}) | {t['max_m'] * 1e3:.1f} mm "
                f"| {replay * 1e3:.2f} mm |"
            )
    print(f"(work folder: {work})", file=sys.stderr)


if __name__ == "__main__":
    main()
