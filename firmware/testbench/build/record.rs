//! "Recording" of the replay data on the host at build time, with loc-core's test kit: a
//! straight 5 m tunnel with the paper's P1 triangular landmarks, its map flash image exactly
//! as it is flashed (and the images of the same tunnel continued to 1 km and 10 km,
//! `map_1km.bin`, `map_10km.bin`), the start pose the controller is given (the truth 0.34 m and
//! 0.02 rad off), and LMS511 scans (1141 beams, 10 mm noise, each beam taken as the mirror
//! swept past it) along a drive through it as the CoLa-B `LMDscandata` telegrams an LMS511
//! sends, with the true poses and a 2 %-scale-error odometry between scans.
//!
//! Written into OUT_DIR (`map.bin`, `start_pose.bin`, `scans_colab.bin`, `recording.rs`)
//! and embedded by `src/recorded.rs`; `scans_colab.bin` is also what the LMS5xx emulator
//! serves the controller in the QEMU hardware-in-the-loop test, with `map.bin` and
//! `start_pose.bin` in the map flash region.

use std::fmt::Write as _;
use std::fs;
use std::path::Path;

use lidar_driver::{ChannelRepr, CommandType, Dialect, ScanHeader, ScanRepr};
use loc_core::filter::OdometryIncrement;
use loc_core::geometry::Pose2;
use loc_core::landmark::LandmarkModel;
use loc_core::localizer::StartPose;
use loc_core::map::TunnelMap;
use loc_core::scan::{SensorSetup, SweepMotion, LMS511_MAX_BEAMS};
use loc_core::testkit::{LandmarkLayout, ScanSimulator, TunnelSpec};

/// Tunnel length, metres.
const TUNNEL_LENGTH_M: f32 = 120.0;
/// Seed of the landmark spacing draws.
const LAYOUT_SEED: u64 = 7;
/// Seed of the range noise.
const NOISE_SEED: u64 = 11;
/// Scans recorded (1.6 s at 25 Hz).
const SCANS: usize = 40;
/// Chainage of the first scan, metres.
const START_S_M: f32 = 20.0;
/// Travel between scans, metres (10 m/s at 25 Hz).
const STEP_M: f32 = 0.4;
/// Time between scans, seconds (25 Hz).
const SCAN_PERIOD_S: f32 = 0.04;
/// Time between beams, seconds: the LMS511's 54 kHz shots at 25 Hz and 1/6°.
const BEAM_PERIOD_S: f32 = 1.0 / 54_000.0;
/// Odometry scale error (a skid-steer loader drifts 1–5 % of distance).
const ODOMETRY_SCALE: f32 = 1.02;
/// Error of the start pose given to the controller: x, y (metres), heading (radians).
const INITIAL_ERROR: [f32; 3] = [0.3, -0.15, 0.02];
/// 1σ of the start pose: position (metres, each axis), heading (radians).
const INITIAL_SIGMA: [f32; 2] = [0.5, 0.05];

/// The true pose at scan `k`: along the centre line, weaving up to 0.4 m sideways, heading
/// a few degrees off the tunnel axis.
fn true_pose(spec: &TunnelSpec, k: usize) -> Pose2 {
    let s = START_S_M + k as f32 * STEP_M;
    let lateral_m = 0.4 * (0.15 * k as f32).sin();
    let centre = spec.centre_pose(s, lateral_m);
    Pose2::new(
        centre.x_m,
        centre.y_m,
        centre.theta_rad + 0.04 * (0.1 * k as f32).cos(),
    )
}

/// Scan `k` as a CoLa-B `sSN LMDscandata` telegram of an LMS511 at 25 Hz, 0.1667°, DIST1
/// only, −5° … +185°.
fn scan_telegram(k: usize, values: Vec<u16>) -> Vec<u8> {
    let counter = k as u16;
    let repr = ScanRepr {
        command_type: CommandType::Event,
        header: ScanHeader {
            version: 0,
            device_number: 1,
            serial_number: 0x0123_4567,
            device_status: [0, 0],
            telegram_counter: counter,
            scan_counter: counter,
            time_since_startup_us: 40_000 * k as u32,
            time_of_transmission_us: 40_000 * k as u32 + 30_000,
            input_status: [0, 0],
            output_status: [0, 0],
            reserved_layer_angle: 0,
            scan_frequency_1e2_hz: 2500,
            measurement_frequency_100hz: 540,
        },
        encoders: Vec::new(),
        channels16: vec![ChannelRepr {
            name: *b"DIST1",
            scale_factor: 1.0,
            scale_offset: 0.0,
            start_angle_1e4_deg: -50_000,
            step_1e4_deg: 1_667,
            values,
        }],
        channels8: Vec::new(),
        position: None,
        device_name: None,
        comment: None,
        time: None,
        event: None,
    };
    repr.to_vec(Dialect::ColaB)
        .expect("an LMS511 scan emits as CoLa-B")
}

/// Capacity of the long map at build time (host memory): 10 km of walls every metre and a
/// landmark every ~9 m on each wall.
type LongMap = loc_core::map::StoredMap<32768, 4096, 32768, 131072>;

/// The map image of the recording's tunnel continued to `length_m`: the same walls and,
/// drawn from the same seeded spacings, the same landmarks over the recorded drive, so the
/// recorded scans localise against it exactly as against the short one.
fn write_long_map(out: &Path, length_m: f32, name: &str) {
    let spec = TunnelSpec::straight(length_m).with_landmarks(LandmarkLayout::paper(
        LandmarkModel::P1Triangle,
        LAYOUT_SEED,
    ));
    let mut map = Box::new(LongMap::new());
    spec.build_into(&mut map)
        .expect("the long tunnel fits the build-time map");
    let mut bytes = vec![0u8; map.image_len()];
    map.write_image(&mut bytes).expect("long map image writes");
    fs::write(out.join(name), &bytes).expect("write the long map image");
}

/// The odometry the vehicle sends on its odometry port: one `controller-wire` frame per scan
/// with the cumulative odometry pose (the recorded increments, 2 % scale error included,
/// integrated from the origin of the odometry frame), 40 ms apart, and line garbage after the
/// tenth (which a reader must drop as one malformed frame).
fn odometry_frames(spec: &TunnelSpec) -> Vec<u8> {
    use controller_wire::{OdometryFrame, MAX_ODOMETRY_FRAME_BYTES};
    let mut bytes = Vec::new();
    let mut odo = Pose2::new(0.0, 0.0, 0.0);
    let mut previous: Option<Pose2> = None;
    for k in 0..SCANS {
        let pose = true_pose(spec, k);
        if let Some(p) = previous {
            let inc = OdometryIncrement::between(&p, &pose);
            odo = odo.compose(&Pose2::new(
                inc.dx_m * ODOMETRY_SCALE,
                inc.dy_m * ODOMETRY_SCALE,
                inc.dtheta_rad,
            ));
        }
        previous = Some(pose);
        let frame = OdometryFrame {
            sequence: k as u32,
            time_us: 40_000 * k as u64,
            x_m: odo.x_m,
            y_m: odo.y_m,
            theta_rad: odo.theta_rad,
        };
        let mut buf = [0u8; MAX_ODOMETRY_FRAME_BYTES];
        bytes.extend_from_slice(frame.encode(&mut buf).expect("odometry frame encodes"));
        if k == 10 {
            bytes.extend_from_slice(&[0x13, 0x37, 0x42, 0x00]);
        }
    }
    bytes
}

/// Writes the recording into `out`.
pub fn write_recordings(out: &Path) {
    let spec = TunnelSpec::straight(TUNNEL_LENGTH_M).with_landmarks(LandmarkLayout::paper(
        LandmarkModel::P1Triangle,
        LAYOUT_SEED,
    ));
    let mut map = Box::new(TunnelMap::new());
    spec.build_into(&mut map)
        .expect("test kit tunnel fits the firmware's TunnelMap");
    let mut map_bytes = vec![0u8; map.image_len()];
    let n = map.write_image(&mut map_bytes).expect("map image writes");
    fs::write(out.join("map.bin"), &map_bytes).expect("write map.bin");
    write_long_map(out, 1_000.0, "map_1km.bin");
    write_long_map(out, 10_000.0, "map_10km.bin");

    let setup = SensorSetup::lms511_forward(0.0, 0.0);
    let mut sim = ScanSimulator::new(NOISE_SEED);
    let mut ranges_m = [0.0f32; LMS511_MAX_BEAMS];
    let mut offsets = String::new();
    let mut truth = String::new();
    let mut odometry = String::new();
    let mut previous: Option<Pose2> = None;
    let mut colab = Vec::new();
    for k in 0..SCANS {
        let pose = true_pose(&spec, k);
        // As the LMS511's mirror sweeps: each beam from where the vehicle was when it was
        // taken (21 ms over the 1141 beams, 21 cm at 10 m/s), the scan stamped at its last.
        let after = k.max(1);
        let motion = SweepMotion::from_motion(
            &true_pose(&spec, after - 1).between(&true_pose(&spec, after)),
            SCAN_PERIOD_S,
        )
        .expect("the drive moves");
        sim.simulate_swept(
            &*map,
            |before_s| pose.compose(&motion.pose_before(before_s)),
            BEAM_PERIOD_S,
            &setup,
            &mut ranges_m,
        );
        // What the LMS511 reports: whole millimetres (65534 at most: 0xFFFF reads as
        // saturated), 0 = no echo.
        let values = ranges_m
            .iter()
            .map(|r_m| (r_m * 1000.0).round().clamp(0.0, 65534.0) as u16)
            .collect();
        let telegram = scan_telegram(k, values);
        writeln!(offsets, "    ({}, {}),", colab.len(), telegram.len()).unwrap();
        colab.extend(telegram);
        writeln!(
            truth,
            "    [{:?}, {:?}, {:?}],",
            pose.x_m, pose.y_m, pose.theta_rad
        )
        .unwrap();
        let inc = previous.map_or(
            OdometryIncrement {
                dx_m: 0.0,
                dy_m: 0.0,
                dtheta_rad: 0.0,
            },
            |p| OdometryIncrement::between(&p, &pose),
        );
        writeln!(
            odometry,
            "    [{:?}, {:?}, {:?}],",
            inc.dx_m * ODOMETRY_SCALE,
            inc.dy_m * ODOMETRY_SCALE,
            inc.dtheta_rad
        )
        .unwrap();
        previous = Some(pose);
    }
    fs::write(out.join("scans_colab.bin"), colab).expect("write scans_colab.bin");
    fs::write(out.join("odometry_frames.bin"), odometry_frames(&spec))
        .expect("write odometry_frames.bin");
    let truth0 = true_pose(&spec, 0);
    let start = StartPose {
        pose: Pose2::new(
            truth0.x_m + INITIAL_ERROR[0],
            truth0.y_m + INITIAL_ERROR[1],
            truth0.theta_rad + INITIAL_ERROR[2],
        ),
        sigma_xy_m: INITIAL_SIGMA[0],
        sigma_theta_rad: INITIAL_SIGMA[1],
    };
    fs::write(out.join("start_pose.bin"), start.to_bytes()).expect("write start_pose.bin");
    // The configuration record of this vehicle: the LMS511 at the origin looking forward,
    // loc-core's defaults otherwise (what the scans above were simulated with).
    let mut config = vec![0u8; loc_core::localizer::CONFIG_RECORD_MAX_BYTES];
    let config_len = loc_core::localizer::LocalizerConfig::default()
        .to_record(&mut config)
        .expect("the configuration record writes");
    fs::write(out.join("config.bin"), &config[..config_len]).expect("write config.bin");
    let landmarks = map.landmarks().len();
    let src = format!(
        "/// Scans in the recording.\npub const SCAN_COUNT: usize = {SCANS};\n\
         /// Beams per scan.\npub const BEAMS_PER_SCAN: usize = {LMS511_MAX_BEAMS};\n\
         /// Landmarks in the recorded map.\npub const MAP_LANDMARKS: usize = {landmarks};\n\
         /// Length of the map image, bytes.\npub const MAP_BYTES_LEN: usize = {n};\n\
         /// Error of the recorded start pose against the first true pose: x_m, y_m, theta_rad.\n\
         pub const INITIAL_ERROR: [f32; 3] = {INITIAL_ERROR:?};\n\
         /// `(offset, length)` of each scan's telegram in the CoLa-B stream, bytes.\n\
         pub const TELEGRAMS: [(usize, usize); {SCANS}] = [\n{offsets}];\n\
         /// True vehicle pose `[x_m, y_m, theta_rad]` (world frame) at each scan.\n\
         pub const TRUE_POSES: [[f32; 3]; {SCANS}] = [\n{truth}];\n\
         /// Odometry since the previous scan `[dx_m, dy_m, dtheta_rad]` (vehicle frame; \
         translation with a {ODOMETRY_SCALE} scale error; zero for the first scan).\n\
         pub const ODOMETRY: [[f32; 3]; {SCANS}] = [\n{odometry}];\n"
    );
    fs::write(out.join("recording.rs"), src).expect("write recording.rs");
}
