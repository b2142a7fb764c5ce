//! `lms5xx-emulator`: an emulated SICK LMS5xx on 127.0.0.1 (or a serial port / pty) that
//! answers the start-up sequence in CoLa-A and CoLa-B and streams the scans of a recording in a
//! loop, to run drivers against by hand. It answers what the recorded sensor answered
//! (FirmwareVersion, LocationName, output range, … where the recording has them).
//!
//! ```text
//! lms5xx-emulator --recording lms511_20210302_colab.pcapng.json            # TCP 127.0.0.1:2112
//! lms5xx-emulator --recording REC --port 0 --rate-hz 50 --startup-delay-ms 30000
//! lms5xx-emulator --recording REC --serial /dev/pts/5 --baud 115200
//! lms5xx-emulator --recording REC --drop-after-scans 100 --corrupt-every 7 --duration-s 60
//! lms5xx-emulator --recording REC --max-connections 2 --idle-timeout-s 10 --partial-frame-timeout-ms 500
//! ```
//!
//! Prints its address, then the counters once a second until `--duration-s` ends or Ctrl-C.

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::{Duration, Instant};

use clap::{Parser, ValueEnum};
use lidar_driver::recording::Recording;
use lidar_driver::Dialect;
use lms5xx_emulator::{
    DeviceIdentity, DialectMode, Emulator, EmulatorConfig, Faults, Limits, RecordingSource,
};

/// Dialect choice on the command line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
enum DialectArg {
    /// Whatever each connection's first frame uses.
    Auto,
    /// CoLa-A only (ASCII).
    A,
    /// CoLa-B only (binary).
    B,
}

/// Emulated SICK LMS5xx: CoLa-A / CoLa-B start-up answers like the LMS511, scans from a
/// recording, optional busy start-up and fault injection. Listens on 127.0.0.1 only.
#[derive(Debug, Parser)]
#[command(name = "lms5xx-emulator", version)]
struct Cli {
    /// TCP port on 127.0.0.1 (0 = any free port, printed at start).
    #[arg(long, default_value_t = 2112)]
    port: u16,
    /// Recording to replay in a loop (raw CoLa stream, pcap, pcapng or SICK .pcapng.json).
    #[arg(long)]
    recording: PathBuf,
    /// Scan rate at power-up, Hz (mLMPsetscancfg changes it).
    #[arg(long, default_value_t = 25.0)]
    rate_hz: f32,
    /// Report busy (SCdevicestate 0, other requests sFA 13) this long after start, ms.
    #[arg(long, default_value_t = 0)]
    startup_delay_ms: u64,
    /// Dialect.
    #[arg(long, value_enum, default_value_t = DialectArg::Auto)]
    dialect: DialectArg,
    /// Serve this serial port / pty instead of TCP.
    #[arg(long)]
    serial: Option<String>,
    /// Baud rate with --serial.
    #[arg(long, default_value_t = 115_200)]
    baud: u32,
    /// Close each connection after this many scans (at most --max-drops times).
    #[arg(long)]
    drop_after_scans: Option<u64>,
    /// Connections dropped by --drop-after-scans at most (default: every connection).
    #[arg(long)]
    max_drops: Option<u32>,
    /// Send garbage before every n-th scan.
    #[arg(long)]
    garbage_every: Option<u64>,
    /// Damage every n-th scan frame.
    #[arg(long)]
    corrupt_every: Option<u64>,
    /// TCP connections served at once; one more is closed as soon as it is accepted.
    #[arg(long, default_value_t = Limits::default().max_connections)]
    max_connections: usize,
    /// Close a connection that sends nothing for this long while not streaming scans, s
    /// (TCP only).
    #[arg(long, default_value_t = Limits::default().idle_timeout.as_secs())]
    idle_timeout_s: u64,
    /// Drop a telegram still incomplete this long after it began (a length longer than what
    /// follows), so the next requests are answered, ms.
    #[arg(long, default_value_t = Limits::default().partial_frame_timeout.as_millis() as u64)]
    partial_frame_timeout_ms: u64,
    /// Stop after this many seconds (default: run until interrupted).
    #[arg(long)]
    duration_s: Option<u64>,
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    if !(cli.rate_hz.is_finite() && cli.rate_hz > 0.0 && cli.rate_hz <= 1000.0) {
        eprintln!("lms5xx-emulator: --rate-hz must be in (0, 1000]");
        return ExitCode::FAILURE;
    }
    if cli.max_connections == 0 || cli.idle_timeout_s == 0 || cli.partial_frame_timeout_ms == 0 {
        eprintln!(
            "lms5xx-emulator: --max-connections, --idle-timeout-s and --partial-frame-timeout-ms \
             must be at least 1"
        );
        return ExitCode::FAILURE;
    }
    let rec = match Recording::read_file(&cli.recording) {
        Ok(r) => r,
        Err(e) => {
            eprintln!("lms5xx-emulator: {}: {e}", cli.recording.display());
            return ExitCode::FAILURE;
        }
    };
    let source = match RecordingSource::from_recording(&rec) {
        Ok(s) => s,
        Err(e) => {
            eprintln!("lms5xx-emulator: {}: {e}", cli.recording.display());
            return ExitCode::FAILURE;
        }
    };
    // Answer what the recorded sensor answered (LMS511 capture values where it is silent).
    let identity = DeviceIdentity::from_recording(&rec);
    drop(rec);
    let n_scans = source.scans().len();
    let config = EmulatorConfig {
        port: cli.port,
        dialect: match cli.dialect {
            DialectArg::Auto => DialectMode::Auto,
            DialectArg::A => DialectMode::Only(Dialect::ColaA),
            DialectArg::B => DialectMode::Only(Dialect::ColaB),
        },
        rate_hz: cli.rate_hz,
        startup_delay: Duration::from_millis(cli.startup_delay_ms),
        faults: Faults {
            drop_after_scans: cli.drop_after_scans,
            max_drops: cli.max_drops,
            garbage_every: cli.garbage_every,
            corrupt_every: cli.corrupt_every,
            silent: false,
        },
        identity,
        restamp: true,
        limits: Limits {
            max_connections: cli.max_connections,
            idle_timeout: Duration::from_secs(cli.idle_timeout_s),
            partial_frame_timeout: Duration::from_millis(cli.partial_frame_timeout_ms),
        },
    };
    let started = match &cli.serial {
        Some(path) => serialport::new(path, cli.baud)
            .timeout(Duration::from_millis(2))
            .open()
            .map_err(std::io::Error::from)
            .and_then(|port| Emulator::start_on_stream(config, source, port)),
        None => Emulator::start(config, source),
    };
    let emu = match started {
        Ok(e) => e,
        Err(e) => {
            eprintln!("lms5xx-emulator: cannot start: {e}");
            return ExitCode::FAILURE;
        }
    };
    match (emu.addr(), &cli.serial) {
        (Some(a), _) => println!("lms5xx-emulator: listening on {a}, {n_scans} recorded scans"),
        (None, Some(p)) => println!("lms5xx-emulator: serving {p}, {n_scans} recorded scans"),
        (None, None) => {}
    }
    let end = cli
        .duration_s
        .map(|s| Instant::now() + Duration::from_secs(s));
    while end.is_none_or(|e| Instant::now() < e) {
        std::thread::sleep(Duration::from_secs(1));
        let s = emu.stats();
        println!(
            "connections {} refused {} idle-closed {} requests {} sFA {} scans {} drops {} \
             corrupted {} garbage {} partial-dropped {}",
            s.connections,
            s.refused_connections,
            s.idle_closed,
            s.requests,
            s.errors_sent,
            s.scans_sent,
            s.drops,
            s.corrupted_scans,
            s.garbage_injections,
            s.partial_frames_dropped
        );
    }
    let s = emu.stop();
    println!("lms5xx-emulator: stopped after {} scans", s.scans_sent);
    ExitCode::SUCCESS
}
