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


def truth_pose_at(rec):
    """A function t -> true vehicle pose (x, y, theta) from the recording's ground truth."""
    import bisect
    import csv
    rows = [(float(r["t_s"]), float(r["x_m"]), float(r["y_m"]), float(r["theta_rad"]))
            for r in csv.DictReader(open(os.path.join(rec, "ground_truth.csv")))]
    times = [r[0] for r in rows]
    return lambda t: rows[min(bisect.bisect_left(times, t), len(rows) - 1)][1:]


def pair_found(bootstrap_csv, rec, landmarks):
    """The drive's own landmarks (bootstrap.csv of `survey --without-map`) paired with the true
    ones: each placed by the true pose of the keyframe nearest it (its map is in the drive's
    frame, not the truth's), then the nearest true landmark on its wall within 0.5 m.
    Returns {found index: true index}."""
    import csv
    import math
    at = truth_pose_at(rec)
    out = {}
    for r in csv.DictReader(open(bootstrap_csv)):
        x, y, th = at(float(r["nearest_t_s"]))
        u, v = float(r["in_nearest_x_m"]), float(r["in_nearest_y_m"])
        p = (x + math.cos(th) * u - math.sin(th) * v, y + math.sin(th) * u + math.cos(th) * v)
        best = min(((math.dist(p, centre(l)), i) for i, l in enumerate(landmarks) if l["wall"] == r["wall"]),
                   default=(1e9, None))
        if best[0] <= 0.5:
            out[int(r["index"])] = best[1]
    return out


def shape_error(landmarks_csv, pairs, landmarks):
    """RMS along / across and max of a survey's landmarks against the truth after the best
    rigid fit (rotation and translation): how far the map is from the tunnel's shape, the
    frame set aside (a map relative to its first landmark has the drive's start frame)."""
    import csv
    import math
    est, tru = [], []
    for r in csv.DictReader(open(landmarks_csv)):
        j = int(r["prior_index"])
        if r["map_index"] and j in pairs:
            est.append((float(r["x_m"]), float(r["y_m"])))
            tru.append(pairs[j])
    n = len(est)
    me = (sum(p[0] for p in est) / n, sum(p[1] for p in est) / n)
    tc = [centre(landmarks[i]) for i in tru]
    mt = (sum(p[0] for p in tc) / n, sum(p[1] for p in tc) / n)
    sxx = sum((e[0] - me[0]) * (t[0] - mt[0]) + (e[1] - me[1]) * (t[1] - mt[1]) for e, t in zip(est, tc))
    sxy = sum((e[0] - me[0]) * (t[1] - mt[1]) - (e[1] - me[1]) * (t[0] - mt[0]) for e, t in zip(est, tc))
    a = math.atan2(sxy, sxx)
    c, s = math.cos(a), math.sin(a)
    errs = []
    for e, i in zip(est, tru):
        p = (mt[0] + c * (e[0] - me[0]) - s * (e[1] - me[1]), mt[1] + s * (e[0] - me[0]) + c * (e[1] - me[1]))
        poly = landmarks[i]["polyline"]
        tx, ty = poly[-1][0] - poly[0][0], poly[-1][1] - poly[0][1]
        norm = math.hypot(tx, ty)
        t0 = centre(landmarks[i])
        d = (p[0] - t0[0], p[1] - t0[1])
        errs.append(((d[0] * tx + d[1] * ty) / norm, (-d[0] * ty + d[1] * tx) / norm))
    rms = lambda v: math.sqrt(sum(x * x for x in v) / len(v))
    return {
        "rms_m": rms([math.hypot(*e) for e in errs]),
        "rms_along_m": rms([e[0] for e in errs]),
        "rms_across_m": rms([e[1] for e in errs]),
        "max_m": max(math.hypot(*e) for e in errs),
        "paired": n,
    }


def survey_and_replay(rec, out, args):
    """Surveys `rec` into `out` with `args`; the survey's own score and `replay`'s RMS on it."""
    host_sim("survey", rec, "--out", out, "--quiet", *args)
    t = json.load(open(os.path.join(out, "survey.json")))["against_truth"]["surveyed"]
    replay = json.loads(host_sim("replay", rec, "--map", os.path.join(out, "survey.postcard"), "--json"))
    return t, replay["position_rms_m"]


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
            args = []
            if idx is not None:
                args.append("--no-design-prior")
                for i in idx:
                    x, y = centre(landmarks[i])
                    args += ["--anchor", f"{i},{x:.4f},{y:.4f}"]
            t, replay = survey_and_replay(rec, out, args)
            rows.append((odometry, name, len(idx) if idx else 0, t, replay))
            print(f"  {name}: {t['rms_m'] * 1e3:.1f} mm", file=sys.stderr)
        # Without any prior map: the drive's own map, relative to its first landmark (scored
        # after a rigid fit), or tied to anchors (its landmarks paired with the true ones to
        # name them, as a surveyor names the landmarks they surveyed).
        out = os.path.join(work, f"{os.path.basename(rec)}-nomap")
        host_sim("survey", rec, "--out", out, "--quiet", "--without-map")
        pairs = pair_found(os.path.join(out, "bootstrap.csv"), rec, landmarks)
        found_of = {t: f for f, t in pairs.items()}
        t = shape_error(os.path.join(out, "landmarks.csv"), pairs, landmarks)
        replay = json.loads(host_sim("replay", rec, "--map", os.path.join(out, "survey.postcard"), "--json"))
        rows.append((odometry, "no map: relative (rigid fit)", 0, t, replay["position_rms_m"]))
        print(f"  no map, relative: {t['rms_m'] * 1e3:.1f} mm", file=sys.stderr)
        for name, idx in setups[1:4]:
            idx = [i for i in idx if i in found_of]
            out = os.path.join(work, f"{os.path.basename(rec)}-nomap-{len(rows)}")
            args = ["--without-map"]
            for i in idx:
                x, y = centre(landmarks[i])
                args += ["--anchor", f"{found_of[i]},{x:.4f},{y:.4f}"]
            t, replay = survey_and_replay(rec, out, args)
            rows.append((odometry, f"no map: {name}", len(idx), t, replay))
            print(f"  no map, {name}: {t['rms_m'] * 1e3:.1f} mm", file=sys.stderr)
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
