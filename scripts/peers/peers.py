#!/usr/bin/env python3
"""Runs a peer localiser (KISS-ICP's or small_gicp's registration) as a scan-to-map localiser
over a `host-sim run --record` recording and writes its per-scan poses as an estimates CSV
that `host-sim replay DIR --estimates FILE --json` scores with the project's own metrics.

Each scan: predict from the previous estimate with the recorded odometry increments (the
same `dx_m, dy_m, dtheta_rad` rows the core's replay feeds its EKF, composed in the vehicle
frame, up to the scan's own time as the replay predicts), register the scan (LMS511 DIST1
through the exact beam step `sick-dump` reports, mounted as the recording's scenario says)
against the stored map (walls and landmark polylines of `host-sim export-map --format
json`, sampled densely), and take the registered pose as the estimate. No filter: these are
registration methods.

Inputs are the files the comparison script prepares; see compare.sh.
"""

import argparse
import json
import math
import sys
import time
import tomllib

import numpy as np


# --- recording --------------------------------------------------------------------------


def read_csv(path):
    with open(path) as f:
        header = f.readline().strip().split(",")
        rows = [line.strip().split(",") for line in f if line.strip()]
    return header, rows


def read_numeric(path, columns):
    header, rows = read_csv(path)
    idx = [header.index(c) for c in columns]
    return np.array([[float(r[i]) for i in idx] for r in rows], dtype=np.float64)


def read_scans(jsonl_path, times_path):
    """(t_s, ranges_m, angles_rad, before_s) per scan, in the sensor frame, invalid beams
    dropped; `before_s`: how long before the scan's last beam (its time) each beam was
    taken, from the telegram's scan frequency and step (the mirror's sweep).

    Times come from the recording's times file, paired by telegram counter as the replay
    pairs them."""
    header, rows = read_csv(times_path)
    c_t, c_k = header.index("t_s"), header.index("telegram_counter")
    time_of = {int(float(r[c_k])): float(r[c_t]) for r in rows}
    scans = []
    with open(jsonl_path) as f:
        for line in f:
            d = json.loads(line)
            t = time_of.get(d["telegram_counter"])
            if t is None:
                continue
            ch = next(c for c in d["channels"] if c["name"] == "DIST1")
            v = np.asarray(ch["values"], dtype=np.float64)
            step = math.radians(ch["beam_step_deg"])
            start = math.radians(ch["start_angle_deg"])
            a = start + step * np.arange(len(v))
            ok = (v > 0) & (v < 0xFFFF)
            r = (v * ch["scale_factor"] + ch["scale_offset"]) / 1000.0
            beam_s = ch["beam_step_deg"] / 360.0 / d["scan_frequency_hz"]
            before = (len(v) - 1 - np.arange(len(v))) * beam_s
            scans.append((t, r[ok], a[ok], before[ok]))
    return scans


class Odometry:
    """The recorded odometry (`odometry.csv` rows `t_s, dt_s, dx_m, dy_m, dtheta_rad`) as
    the vehicle's odometry pose at any time, the way the core's replay predicts each scan
    (host-sim's `GapTracker::lead`): every row up to the time, then on at the last row's rate
    up to it while the next row is normally awaited (1.5 of its intervals). Scans between
    rows (35 or 75 Hz against 100 Hz odometry) are predicted to their own time, not to the
    row before them; at 25 and 50 Hz every scan falls on a row."""

    def __init__(self, rows):
        self.t = rows[:, 0]
        self.dt = rows[:, 1]
        self.inc = rows[:, 2:5]
        # Pose after each row (vehicle frame at the log's start); index 0: before any.
        self.cum = [(0.0, 0.0, 0.0)]
        for d in self.inc:
            self.cum.append(compose(self.cum[-1], d))

    def at(self, t):
        k = int(np.searchsorted(self.t, t, side="right"))  # rows with t_s <= t
        pose = self.cum[k]
        if k > 0:
            lead = t - self.t[k - 1]
            dt = self.dt[k - 1]
            if dt > 0 and 0 < lead <= 1.5 * dt:
                pose = compose(pose, tuple(self.inc[k - 1] * (lead / dt)))
        return pose

    def between(self, t0, t1):
        """The motion from t0 to t1, (dx, dy, dth) in the vehicle frame at t0."""
        a, b = self.at(t0), self.at(t1)
        c, s = math.cos(a[2]), math.sin(a[2])
        dx, dy = b[0] - a[0], b[1] - a[1]
        return (c * dx + s * dy, -s * dx + c * dy, b[2] - a[2])


def compose(p, d):
    c, s = math.cos(p[2]), math.sin(p[2])
    return (p[0] + c * d[0] - s * d[1], p[1] + s * d[0] + c * d[1], p[2] + d[2])


def map_points(map_json, step_m):
    """The stored map's walls and landmark polylines sampled every `step_m` (world frame)."""
    m = json.load(open(map_json))
    lines = [m["left_wall"], m["right_wall"]] + [lm["polyline"] for lm in m["landmarks"]]
    pts = []
    for line in lines:
        p = np.asarray(line, dtype=np.float64)
        for a, b in zip(p[:-1], p[1:]):
            n = max(1, int(math.ceil(np.linalg.norm(b - a) / step_m)))
            u = np.arange(n) / n
            pts.append(a + (b - a) * u[:, None])
        pts.append(p[-1:])
    return np.concatenate(pts)


def pose_matrix(p):
    c, s = math.cos(p[2]), math.sin(p[2])
    t = np.eye(4)
    t[0, 0], t[0, 1], t[1, 0], t[1, 1] = c, -s, s, c
    t[0, 3], t[1, 3] = p[0], p[1]
    return t


def matrix_pose(t, near_theta):
    th = math.atan2(t[1, 0], t[0, 0])
    th += 2 * math.pi * round((near_theta - th) / (2 * math.pi))
    return (t[0, 3], t[1, 3], th)


def lift(xy, layers):
    """2D points to 3D: at z = 0, or copied on `layers` heights (a vertical extrusion, so that
    normals and covariances of a planar scan are those of the walls, not of the scan plane)."""
    if not layers:
        return np.column_stack([xy, np.zeros(len(xy))])
    return np.concatenate([np.column_stack([xy, np.full(len(xy), z)]) for z in layers])


# --- peers ------------------------------------------------------------------------------


class KissIcp:
    """KISS-ICP's registration (point-to-point ICP, Geman–McClure kernel, voxel hash map)
    against the stored map loaded once into its VoxelHashMap."""

    def __init__(self, world_xy, cfg):
        from kiss_icp.mapping import VoxelHashMap
        from kiss_icp.registration import Registration

        self.cfg = cfg
        self.map = VoxelHashMap(
            voxel_size=cfg["voxel_m"], max_distance=1e6, max_points_per_voxel=cfg["points_per_voxel"]
        )
        self.map.add_points(lift(world_xy, None))
        self.reg = Registration(
            max_num_iterations=cfg["iterations"], convergence_criterion=cfg["convergence"], max_num_threads=1
        )

    def register(self, pts_xy, guess):
        src = lift(pts_xy, None)
        if self.cfg["scan_voxel_m"] > 0:
            from kiss_icp.voxelization import voxel_down_sample

            src = voxel_down_sample(src, self.cfg["scan_voxel_m"])
        return self.reg.align_points_to_map(
            src, self.map, guess, self.cfg["max_distance_m"], self.cfg["kernel_m"]
        )


class SmallGicp:
    """small_gicp's ICP / point-to-plane ICP / GICP against the stored map, extruded
    vertically (see `lift`), with a KdTree built once."""

    def __init__(self, world_xy, cfg):
        import small_gicp

        self.sg = small_gicp
        self.cfg = cfg
        layers = cfg["layers"]
        tgt = lift(world_xy, layers)
        self.target, self.tree = small_gicp.preprocess_points(
            tgt, downsampling_resolution=cfg["map_resolution_m"], num_neighbors=cfg["neighbours"], num_threads=1
        )

    def register(self, pts_xy, guess):
        src = lift(pts_xy, self.cfg["layers"])
        source, _ = self.sg.preprocess_points(
            src, downsampling_resolution=self.cfg["scan_resolution_m"], num_neighbors=self.cfg["neighbours"], num_threads=1
        )
        r = self.sg.align(
            self.target,
            source,
            self.tree,
            init_T_target_source=guess,
            registration_type=self.cfg["type"],
            max_correspondence_distance=self.cfg["max_distance_m"],
            num_threads=1,
            max_iterations=self.cfg["iterations"],
            rotation_epsilon=1e-7,
            translation_epsilon=1e-7,
        )
        return r.T_target_source


PEERS = {"kiss-icp": KissIcp, "small_gicp": SmallGicp}


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--recording", required=True, help="host-sim run --record directory")
    ap.add_argument("--scans", required=True, help="sick-dump --format jsonl of its scanner stream")
    ap.add_argument("--map", required=True, help="host-sim export-map --format json of its scenario")
    ap.add_argument("--peer", required=True, choices=sorted(PEERS))
    ap.add_argument("--config", required=True, help="the peer's settings, JSON")
    ap.add_argument("--start", choices=["initial", "truth"], default="initial")
    ap.add_argument("--out", required=True, help="estimates CSV to write")
    a = ap.parse_args()

    cfg = json.loads(a.config)
    sc = tomllib.load(open(f"{a.recording}/scenario.toml", "rb"))
    lid = sc.get("lidar", {})
    mount = (lid.get("mount_x_m", 0.0), lid.get("mount_y_m", 0.0), lid.get("mount_yaw_rad", 0.0))
    max_range = cfg.get("max_range_m", lid.get("max_range_m", 80.0))

    scans = read_scans(a.scans, f"{a.recording}/scanner.colab.times.csv")
    odo = Odometry(
        read_numeric(
            f"{a.recording}/odometry.csv", ["t_s", "dt_s", "dx_m", "dy_m", "dtheta_rad"]
        )
    )
    if a.start == "truth":
        t0 = read_numeric(f"{a.recording}/ground_truth.csv", ["x_m", "y_m", "theta_rad"])[0]
    else:
        t0 = read_numeric(f"{a.recording}/initial_pose.csv", ["x_m", "y_m", "theta_rad"])[0]
    pose = tuple(float(v) for v in t0)
    peer = PEERS[a.peer](map_points(a.map, cfg.get("map_step_m", 0.005)), cfg)

    # A scanner that sweeps (`lidar.sweep`): each point carried to the scan's last beam at
    # the constant velocity of the peer's own last two estimates — KISS-ICP's own de-skew
    # (its constant-velocity model), given to every peer.
    sweep = bool(lid.get("sweep", False))
    cm, sm = math.cos(mount[2]), math.sin(mount[2])
    t_prev = 0.0
    rows = []
    started = time.perf_counter()
    for k, (t, r, ang, before) in enumerate(scans):
        pose = compose(pose, odo.between(t_prev, t))
        keep = r <= max_range
        xs, ys = r[keep] * np.cos(ang[keep]), r[keep] * np.sin(ang[keep])
        pts = np.column_stack([mount[0] + cm * xs - sm * ys, mount[1] + sm * xs + cm * ys])
        if sweep and len(rows) >= 2 and t > rows[-1][0] > rows[-2][0]:
            (t1, p1, _), (t2, p2, _) = rows[-2], rows[-1]
            dt = t2 - t1
            c1, s1 = math.cos(p1[2]), math.sin(p1[2])
            dx, dy = p2[0] - p1[0], p2[1] - p1[1]
            vx, vy = (c1 * dx + s1 * dy) / dt, (-s1 * dx + c1 * dy) / dt
            w = math.atan2(math.sin(p2[2] - p1[2]), math.cos(p2[2] - p1[2])) / dt
            tau = before[keep]
            phi = -w * tau
            cp, sp = np.cos(phi), np.sin(phi)
            pts = np.column_stack([
                cp * pts[:, 0] - sp * pts[:, 1] - vx * tau,
                sp * pts[:, 0] + cp * pts[:, 1] - vy * tau,
            ])
        t_prev = t
        t_start = time.perf_counter()
        T = peer.register(pts, pose_matrix(pose))
        us = (time.perf_counter() - t_start) * 1e6
        pose = matrix_pose(T, pose[2])
        rows.append((t, pose, us))
        if k % 200 == 0:
            el = time.perf_counter() - started
            print(f"  {a.peer} {a.start}: scan {k}/{len(scans)} ({el:.0f} s)", file=sys.stderr, flush=True)
    with open(a.out, "w") as f:
        f.write("t_s,est_x_m,est_y_m,est_theta_rad,update_us\n")
        for t, p, us in rows:
            f.write(f"{t:.6f},{p[0]:.7f},{p[1]:.7f},{p[2]:.8f},{us:.1f}\n")


if __name__ == "__main__":
    main()
