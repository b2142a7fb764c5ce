//! `run.mcap`: a run (or a replay) for Foxglove Studio — scans, the true, estimated and
//! odometry poses, the vehicle's frame, and the stored map — as JSON messages with
//! Foxglove's well-known schemas ([`schemas`]).
//!
//! | topic | schema | what |
//! |---|---|---|
//! | `/map` | `foxglove.SceneUpdate` | once, at the first sample: walls (grey) and landmarks (green) as line strips in `world` |
//! | `/tf` | `foxglove.FrameTransform` | per scan: `world → vehicle` (the localiser's estimate) and `world → vehicle_truth` |
//! | `/lidar/scan` | `foxglove.LaserScan` | per kept scan: ranges in metres in frame `vehicle`, origin at the scanner's mounting pose; 0 = no echo |
//! | `/pose/truth`, `/pose/estimate`, `/pose/odometry` | `foxglove.PoseInFrame` | per scan, frame `world` |
//!
//! Log times are the run's time in nanoseconds from 0. Open the file in Foxglove Studio, add
//! a 3D panel with display frame `world`: the scans drawn from the estimated vehicle frame
//! lie on the map's walls when the localiser is right.

pub mod schemas;

use std::collections::BTreeMap;
use std::io::BufWriter;
use std::path::Path;

use mcap::records::MessageHeader;
use serde_json::{json, Value};

use crate::closed_loop::RunLog;
use crate::plot::map_lines::{MapLines, Polyline};
use crate::vehicle::SimPose;

/// File name in the `--out` directory.
pub const FILE_NAME: &str = "run.mcap";

/// Topic names.
pub mod topics {
    /// The stored map.
    pub const MAP: &str = "/map";
    /// Frame transforms.
    pub const TF: &str = "/tf";
    /// Lidar scans.
    pub const SCAN: &str = "/lidar/scan";
    /// True pose.
    pub const TRUTH: &str = "/pose/truth";
    /// Estimated pose.
    pub const ESTIMATE: &str = "/pose/estimate";
    /// Odometry-alone pose.
    pub const ODOMETRY: &str = "/pose/odometry";
}

/// Fixed frame of the map.
pub const WORLD_FRAME: &str = "world";
/// The vehicle frame at the localiser's estimate.
pub const VEHICLE_FRAME: &str = "vehicle";
/// The vehicle frame at the true pose.
pub const TRUTH_FRAME: &str = "vehicle_truth";

/// Why the MCAP file could not be written.
pub type McapOutError = crate::output::OutputError;

fn stamp(t_s: f64) -> Value {
    let ns = (t_s.max(0.0) * 1e9).round() as u64;
    json!({"sec": ns / 1_000_000_000, "nsec": ns % 1_000_000_000})
}

fn nanos(t_s: f64) -> u64 {
    (t_s.max(0.0) * 1e9).round() as u64
}

/// Rotation about z by `yaw_rad` as a quaternion.
fn yaw_quaternion(yaw_rad: f64) -> Value {
    let (s, c) = (0.5 * yaw_rad).sin_cos();
    json!({"x": 0.0, "y": 0.0, "z": s, "w": c})
}

fn pose_json(x_m: f64, y_m: f64, yaw_rad: f64) -> Value {
    json!({"position": {"x": x_m, "y": y_m, "z": 0.0}, "orientation": yaw_quaternion(yaw_rad)})
}

fn pose_in_frame(t_s: f64, p: SimPose) -> Value {
    json!({"timestamp": stamp(t_s), "frame_id": WORLD_FRAME, "pose": pose_json(p.x_m, p.y_m, p.theta_rad)})
}

fn transform(t_s: f64, child: &str, p: SimPose) -> Value {
    json!({
        "timestamp": stamp(t_s),
        "parent_frame_id": WORLD_FRAME,
        "child_frame_id": child,
        "translation": {"x": p.x_m, "y": p.y_m, "z": 0.0},
        "rotation": yaw_quaternion(p.theta_rad)
    })
}

fn line_strip(points: &Polyline, rgb: (f64, f64, f64), thickness_m: f64) -> Value {
    json!({
        "type": 0,
        "pose": pose_json(0.0, 0.0, 0.0),
        "thickness": thickness_m,
        "scale_invariant": false,
        "points": points.iter().map(|&(x, y)| json!({"x": x, "y": y, "z": 0.0})).collect::<Vec<_>>(),
        "color": {"r": rgb.0, "g": rgb.1, "b": rgb.2, "a": 1.0},
        "colors": [],
        "indices": []
    })
}

fn scene(t_s: f64, lines: &MapLines) -> Value {
    let mut prims = vec![
        line_strip(&lines.left_wall, (0.55, 0.55, 0.55), 0.05),
        line_strip(&lines.right_wall, (0.55, 0.55, 0.55), 0.05),
    ];
    prims.extend(
        lines
            .landmarks
            .iter()
            .map(|l| line_strip(l, (0.17, 0.63, 0.17), 0.06)),
    );
    json!({
        "deletions": [],
        "entities": [{
            "timestamp": stamp(t_s),
            "frame_id": WORLD_FRAME,
            "id": "stored-map",
            "lifetime": {"sec": 0, "nsec": 0},
            "frame_locked": false,
            "metadata": [{"key": "source", "value": "loc-core stored map"}],
            "lines": prims
        }]
    })
}

/// Writes the MCAP file of `log` with the map's `lines` to `path`.
pub fn write_mcap(path: &Path, log: &RunLog, lines: &MapLines) -> Result<(), McapOutError> {
    let err = |reason: String| McapOutError {
        path: path.to_path_buf(),
        reason,
    };
    let file = std::fs::File::create(path).map_err(|e| err(e.to_string()))?;
    let mut w = mcap::WriteOptions::new()
        .compression(Some(mcap::Compression::Zstd))
        .profile("")
        .create(BufWriter::new(file))
        .map_err(|e| err(e.to_string()))?;
    let mut channel =
        |schema_name: &str, schema: Value, topic: &str| -> Result<u16, McapOutError> {
            let data = serde_json::to_vec(&schema).map_err(|e| err(e.to_string()))?;
            let id = w
                .add_schema(schema_name, "jsonschema", &data)
                .map_err(|e| err(e.to_string()))?;
            w.add_channel(id, topic, "json", &BTreeMap::new())
                .map_err(|e| err(e.to_string()))
        };
    let map_ch = channel("foxglove.SceneUpdate", schemas::scene_update(), topics::MAP)?;
    let tf_ch = channel(
        "foxglove.FrameTransform",
        schemas::frame_transform(),
        topics::TF,
    )?;
    let scan_ch = channel("foxglove.LaserScan", schemas::laser_scan(), topics::SCAN)?;
    let pose_schema = schemas::pose_in_frame;
    let truth_ch = channel("foxglove.PoseInFrame", pose_schema(), topics::TRUTH)?;
    let est_ch = channel("foxglove.PoseInFrame", pose_schema(), topics::ESTIMATE)?;
    let odo_ch = channel("foxglove.PoseInFrame", pose_schema(), topics::ODOMETRY)?;

    let mut sequence = 0u32;
    let mut put = |w: &mut mcap::Writer<_>, ch: u16, t_s: f64, v: &Value| {
        sequence = sequence.wrapping_add(1);
        let data = serde_json::to_vec(v).map_err(|e| err(e.to_string()))?;
        let t = nanos(t_s);
        w.write_to_known_channel(
            &MessageHeader {
                channel_id: ch,
                sequence,
                log_time: t,
                publish_time: t,
            },
            &data,
        )
        .map_err(|e| err(e.to_string()))
    };
    let t0 = log.samples.first().map_or(0.0, |s| s.t_s);
    put(&mut w, map_ch, t0, &scene(t0, lines))?;
    let lidar = &log.scenario.lidar;
    // Scans are kept one per sample (RunOptions::keep_scans); a run that kept none writes poses.
    let scans = (log.scans.len() == log.samples.len()).then_some(&log.scans);
    for (i, s) in log.samples.iter().enumerate() {
        put(
            &mut w,
            tf_ch,
            s.t_s,
            &transform(s.t_s, VEHICLE_FRAME, s.estimate),
        )?;
        put(
            &mut w,
            tf_ch,
            s.t_s,
            &transform(s.t_s, TRUTH_FRAME, s.truth),
        )?;
        put(&mut w, truth_ch, s.t_s, &pose_in_frame(s.t_s, s.truth))?;
        put(&mut w, est_ch, s.t_s, &pose_in_frame(s.t_s, s.estimate))?;
        put(&mut w, odo_ch, s.t_s, &pose_in_frame(s.t_s, s.odometry))?;
        if let Some(scan) = scans.and_then(|v| v.get(i)) {
            let n = scan.dist1().len().max(1) - 1;
            let msg = json!({
                "timestamp": stamp(scan.t_s),
                "frame_id": VEHICLE_FRAME,
                "pose": pose_json(lidar.mount_x_m, lidar.mount_y_m, lidar.mount_yaw_rad),
                "start_angle": scan.layout.start_angle_rad(),
                "end_angle": scan.layout.beam_angle_rad(n),
                "ranges": (0..scan.dist1().len()).map(|i| scan.range_m(i).unwrap_or(0.0)).collect::<Vec<_>>(),
                "intensities": []
            });
            put(&mut w, scan_ch, scan.t_s, &msg)?;
        }
    }
    w.finish().map_err(|e| err(e.to_string()))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::closed_loop::{run, OdometryOnly, RunOptions};
    use crate::record::scenario_map;
    use crate::scenario::named::named;

    #[test]
    fn foxglove_file_reads_back_with_schemas_channels_and_counts() {
        let mut s = named("paper-10m").unwrap();
        s.drive.end_m = s.drive.start_m + 3.0;
        let world = s.build_world().unwrap();
        let options = RunOptions {
            keep_scans: true,
            progress: None,
            ..Default::default()
        };
        let log = run(&s, &world, &mut OdometryOnly::default(), &options);
        let (map, _) = scenario_map(&s).unwrap();
        let lines = MapLines::of(&map);
        assert!(!lines.landmarks.is_empty() && lines.left_wall.len() > 1);
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join(FILE_NAME);
        write_mcap(&path, &log, &lines).unwrap();

        let bytes = std::fs::read(&path).unwrap();
        let mut counts: BTreeMap<String, usize> = BTreeMap::new();
        let mut first_scan: Option<Value> = None;
        let mut last_time = 0u64;
        for m in mcap::MessageStream::new(&bytes).unwrap() {
            let m = m.unwrap();
            let schema = m.channel.schema.as_ref().unwrap();
            assert_eq!(schema.encoding, "jsonschema");
            assert_eq!(m.channel.message_encoding, "json");
            let expected = match m.channel.topic.as_str() {
                topics::MAP => "foxglove.SceneUpdate",
                topics::TF => "foxglove.FrameTransform",
                topics::SCAN => "foxglove.LaserScan",
                _ => "foxglove.PoseInFrame",
            };
            assert_eq!(schema.name, expected);
            let body: Value = serde_json::from_slice(&m.data).unwrap();
            let declared: Value = serde_json::from_slice(&schema.data).unwrap();
            // Every field sent is declared by the schema.
            for key in body.as_object().unwrap().keys() {
                assert!(
                    declared["properties"].get(key).is_some(),
                    "{expected}: {key}"
                );
            }
            if m.channel.topic == topics::SCAN && first_scan.is_none() {
                first_scan = Some(body);
            }
            assert!(m.log_time >= last_time || m.channel.topic == topics::MAP);
            last_time = last_time.max(m.log_time);
            *counts.entry(m.channel.topic.clone()).or_default() += 1;
        }
        let n = log.samples.len();
        assert!(n > 50);
        assert_eq!(counts[topics::MAP], 1);
        assert_eq!(counts[topics::TF], 2 * n);
        assert_eq!(counts[topics::SCAN], n);
        for t in [topics::TRUTH, topics::ESTIMATE, topics::ODOMETRY] {
            assert_eq!(counts[t], n);
        }
        let scan = first_scan.unwrap();
        assert_eq!(scan["ranges"].as_array().unwrap().len(), 1141);
        let end = scan["end_angle"].as_f64().unwrap().to_degrees();
        assert!((end - 185.0).abs() < 1e-9, "{end}");
        assert_eq!(scan["frame_id"], VEHICLE_FRAME);
    }
}
