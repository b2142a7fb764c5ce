//! Helpers for the session and emulator tests: capture paths, a session loop with a deadline.
#![allow(dead_code)]

use std::sync::OnceLock;
use std::time::{Duration, Instant};

use lidar_driver::clock::StdClock;
use lidar_driver::session::{Event, Session, SessionConfig, Timeouts};
use lidar_driver::Transport;
use lms5xx_emulator::RecordingSource;

pub use sick_captures::path as capture;

/// The 174 scans of the LMS511 capture, replayed in a loop.
pub fn lms511_source() -> RecordingSource {
    RecordingSource::from_file(capture(sick_captures::LMS511_JSON))
        .expect("LMS511 capture readable")
}

/// Time-outs short enough for tests that last seconds.
pub fn fast_timeouts() -> Timeouts {
    Timeouts {
        // Generous against CI load (2 cores shared), short enough for seconds-long tests.
        probe_ms: 800,
        answer_ms: 2000,
        ready_poll_ms: 100,
        ready_ms: 5000,
        scan_ms: 1500,
        first_scan_ms: 3000,
        reconnect_delay_ms: 100,
    }
}

/// Session configuration with [`fast_timeouts`].
pub fn fast_config() -> SessionConfig {
    SessionConfig {
        timeouts: fast_timeouts(),
        ..SessionConfig::default()
    }
}

/// What a run of the session loop saw.
#[derive(Debug, Default)]
pub struct Seen {
    /// Every non-idle, non-scan event, as text.
    pub log: Vec<String>,
    /// DIST1 and RSSI1 values of each scan, in order.
    pub scans: Vec<(Vec<u16>, Vec<u16>)>,
    /// Scan counters.
    pub counters: Vec<u16>,
    /// Scan frequency fields, 1/100 Hz.
    pub frequencies_1e2_hz: Vec<u32>,
    /// The final event if the loop stopped on `Failed`.
    pub failed: Option<String>,
}

/// Polls until `want_scans` scans arrived, the session failed, or `limit` passed.
pub fn run<B: AsRef<[u8]> + AsMut<[u8]>, T: Transport>(
    session: &mut Session<B>,
    link: &mut T,
    want_scans: usize,
    limit: Duration,
) -> Seen {
    // One clock for the whole test process: a session's deadlines must stay in one time base.
    static CLOCK: OnceLock<StdClock> = OnceLock::new();
    let clock = CLOCK.get_or_init(StdClock::new);
    let end = Instant::now() + limit;
    let mut seen = Seen::default();
    while Instant::now() < end && seen.scans.len() < want_scans {
        match session.poll(link, clock) {
            Event::Idle => {}
            Event::Scan(s) => {
                let d: Vec<u16> = s.dist1().map(|c| c.values().collect()).unwrap_or_default();
                let r: Vec<u16> = s
                    .channel("RSSI1")
                    .map(|c| c.values().collect())
                    .unwrap_or_default();
                seen.counters.push(s.header.scan_counter);
                seen.frequencies_1e2_hz.push(s.header.scan_frequency_1e2_hz);
                seen.scans.push((d, r));
            }
            Event::Failed(e) => {
                seen.failed = Some(e.to_string());
                seen.log.push(format!("Failed({e:?})"));
                break;
            }
            other => seen.log.push(format!("{other:?}")),
        }
    }
    seen
}

/// DIST1 and RSSI1 of the recording's scans.
pub fn recorded_values(src: &RecordingSource) -> Vec<(Vec<u16>, Vec<u16>)> {
    src.scans()
        .iter()
        .map(|s| {
            let d = s
                .channels16
                .iter()
                .find(|c| &c.name == b"DIST1")
                .map(|c| c.values.clone())
                .unwrap_or_default();
            let r = s
                .channels8
                .iter()
                .chain(&s.channels16)
                .find(|c| &c.name == b"RSSI1")
                .map(|c| c.values.clone())
                .unwrap_or_default();
            (d, r)
        })
        .collect()
}
