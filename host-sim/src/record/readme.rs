//! The `README.txt` of a recording directory: what each file holds, its columns and units,
//! and how to replay it.

use crate::closed_loop::RunLog;

use super::files;
use super::scanner_telegram::SIMULATED_SERIAL;

/// The README text of a recording of `log` (`stream_bytes`: size of the scanner stream;
/// `map_bytes`: size of the map file).
pub fn text(log: &RunLog, stream_bytes: usize, map_bytes: usize) -> String {
    let s = &log.scenario;
    let rate = s.lidar.rate;
    let duration = log.samples.last().map_or(0.0, |x| x.t_s);
    format!(
        "Recording of a simulated drive (host-sim run --record)
=====================================================

Scenario `{name}`, seed {seed}: {dist:.1} m driven in {duration:.2} s, {scans} scans, {odo} odometry readings.
All times are seconds on one clock that starts at 0 when the vehicle starts; poses are in the
world frame of the map (x, y in metres; headings in radians, counter-clockwise, not wrapped).

{scanner}  ({stream_bytes} bytes)
    The SICK LMS511's CoLa-B byte stream exactly as the scanner sends it over TCP port 2112 or
    its serial host interface: one `sSN LMDscandata` telegram per scan (STX x4, u32 length,
    payload, XOR checksum). Scan frequency {freq} Hz at {step}/10000 deg, {beams} beams from
    -5 deg to +185 deg (sensor frame, 90 deg straight ahead), shot frequency {meas}00 Hz.
    Header: version 0, device number 1, serial {serial}, device status 01 00 on the first
    telegram then 00 00, telegram counter from 1, scan counter and time since start-up (us)
    counted from power-up {power_up} s before the run (the scan's first shot, as the LMS5xx
    stamps it: the sweep before the scan's time in the times file, which is its last
    beam's), time block from 2026-01-01 00:00:00.
    {channels}; range in mm = value x scale factor (1; 2 in a scan with
    an echo beyond 65.534 m), 0 = no (further) echo. No RSSI channels (remission output
    off). Decode it with `sick-dump {scanner}` (lidar-driver).

{times}
    Columns: index, t_s (the vehicle computer's time stamp of the telegram, s; the simulation
    delivers each scan at the instant it is taken, a real logger stamps it on receipt),
    offset_bytes and length_bytes (where the telegram sits in {scanner}), telegram_counter
    (the telegram's own counter: a replay pairs rows and telegrams by it, so a damaged or
    cut telegram loses only itself).

{odometry}
    One row per odometry reading at {odo_hz} Hz. Columns: t_s (end of the interval, s), dt_s
    (interval, s), v_mps (forward speed from the track encoders, m/s), omega_radps (yaw rate,
    rad/s), dx_m, dy_m, dtheta_rad (the motion over the interval in the vehicle frame at its
    start: x forward, y left). The readings include the odometry's errors (scale, slip, noise).

{truth}
    Where the vehicle really was. Columns: t_s, x_m, y_m, theta_rad, distance_m (driven since
    the start), chainage_m (on the tunnel's centre line). The first row is the start (t = 0),
    then one row per scan at the scan's time.

{initial}
    The pose the localiser starts from and its uncertainty: x_m, y_m, theta_rad, sigma_xy_m,
    sigma_theta_rad.

{map}  ({map_bytes} bytes)
    The stored map (walls and landmarks) in loc-core's map file format (LCMP header, version,
    CRC-32, postcard payload): what `host-sim export-map` writes and the firmware flashes.

{scenario}
    The scenario: sensor mounting, localiser settings, and the tunnel (its centre line splits
    the error along and across the tunnel). `host-sim run {scenario}` drives it again.

Replay
------
    host-sim replay DIR            localise from these files and print the same metrics
    host-sim replay DIR --json     the metrics as one JSON object
A real vehicle's recording replays the same way: a directory with the scanner stream (raw
CoLa-B/CoLa-A bytes, pcapng or SICK .pcapng.json), odometry.csv, map.postcard,
initial_pose.csv and scenario.toml; ground_truth.csv is optional (metrics need it).
",
        name = s.name,
        seed = s.seed,
        dist = log.samples.last().map_or(0.0, |x| x.distance_m),
        scans = log.scans.len(),
        odo = log.odometry.len(),
        scanner = files::SCANNER,
        times = files::SCANNER_TIMES,
        odometry = files::ODOMETRY,
        truth = files::GROUND_TRUTH,
        initial = files::INITIAL_POSE,
        map = files::MAP,
        scenario = files::SCENARIO,
        freq = rate.frequency_hz(),
        step = rate.step_1e4_deg(),
        beams = rate.beam_count(),
        meas = rate.measurement_frequency_100hz(),
        serial = SIMULATED_SERIAL,
        power_up = super::scanner_telegram::POWER_UP_BEFORE_RUN_S,
        odo_hz = s.odometry.rate_hz,
        channels = if super::scanner_telegram::output_channel_for(s.lidar.dust.fraction)
            == super::scanner_telegram::OUTPUT_CHANNEL_ECHOES
        {
            "Five 16-bit channels DIST1..DIST5, all five echoes enabled (LMDscandatacfg output\n    \
             channel 0x1F, as there is dust): echo n of a beam in DISTn, in range order (dust\n    \
             before the wall: the wall on a later echo)"
        } else {
            "One 16-bit channel DIST1, the first echo (LMDscandatacfg output channel 0x01: clear\n    \
             air, one echo per beam; with dust the recording carries DIST1..DIST5)"
        },
    )
}
