//! What the session configures on the sensor, and how long it waits for each thing.

use crate::frame::Dialect;
use crate::request::{AccessLevel, EchoFilter, OutputRange, ScanConfig, ScanDataConfig};

/// Every wait of the session has one of these limits (milliseconds of the caller's clock).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Timeouts {
    /// Wait for the answer to the dialect probe (`sRN SCdevicestate`) before trying the other
    /// dialect; after both, the attempt fails with "no answer".
    pub probe_ms: u64,
    /// Wait for the answer to any other request.
    pub answer_ms: u64,
    /// While the device reports busy / error: interval between `sRN SCdevicestate` polls.
    pub ready_poll_ms: u64,
    /// Longest wait for a busy device to become ready (the LMS5xx takes 30–120 s after
    /// power-up); then the attempt fails and the session re-connects.
    pub ready_ms: u64,
    /// No scan for this long while streaming → re-connect and re-initialise (40 ms is one scan
    /// at 25 Hz).
    pub scan_ms: u64,
    /// Wait for the first scan after the subscription (`sEA LMDscandata`) before giving up:
    /// longer than between scans, because a device may start measuring only then (the real
    /// LMS511 took 223 ms, SICK's C++ emulator 1.2 s; SICK's driver waits 5 s).
    pub first_scan_ms: u64,
    /// Pause between a failed attempt and the next connect.
    pub reconnect_delay_ms: u64,
}

impl Default for Timeouts {
    fn default() -> Self {
        Timeouts {
            probe_ms: 1500,
            answer_ms: 3000,
            ready_poll_ms: 1000,
            ready_ms: 180_000,
            scan_ms: 1000,
            first_scan_ms: 5000,
            reconnect_delay_ms: 1000,
        }
    }
}

/// The start-up sequence's settings. `None` fields are only read back (or skipped), not written.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SessionConfig {
    /// Dialect tried first; the other one is tried when the sensor does not answer. After a
    /// detection the detected dialect is tried first on re-connects.
    pub first_dialect: Dialect,
    /// Make the sensor speak this dialect: if it answers in the other one, the session writes
    /// `sWN EIHstCola` after login and re-connects (the switch takes effect on a new
    /// connection). Tried once per [`super::Session`] (until `restart`); `None` = use whatever
    /// the sensor speaks.
    pub switch_dialect: Option<Dialect>,
    /// `SetAccessMode` level (configuration needs [`AccessLevel::AuthorizedClient`]).
    pub access_level: AccessLevel,
    /// Password hash; `None` = the level's SICK default.
    pub password: Option<u32>,
    /// `sWN LMPoutputRange` (then read back and compared); `None` = read only.
    pub output_range: Option<OutputRange>,
    /// `sWN LMDscandatacfg`: channels, echoes (0x1F = five), RSSI, time block.
    pub scan_data: ScanDataConfig,
    /// `sMN mLMPsetscancfg` (then `sRN LMPscancfg` read back and compared); `None` = skip.
    pub scan_config: Option<ScanConfig>,
    /// `sWN FREchoFilter`; `None` = skip.
    pub echo_filter: Option<EchoFilter>,
    /// Time limits.
    pub timeouts: Timeouts,
    /// Consecutive failed attempts (connect, probe, start-up, stream) before the session gives
    /// up with [`super::Event::Failed`]; `None` = retry forever. A scan resets the count.
    pub max_failed_attempts: Option<u32>,
}

impl SessionConfig {
    /// `LMDscandatacfg` of the LMS511 capture: first echo DIST1, 8-bit RSSI1, time block, every
    /// scan (`01 00 01 00 00 00 00 00 00 00 01 00 01`).
    pub const CAPTURE_SCAN_DATA: ScanDataConfig = ScanDataConfig {
        output_channel: 0x01,
        remission: true,
        remission_16bit: false,
        unit: 0,
        encoder: 0,
        position: false,
        device_name: false,
        comment: false,
        time: true,
        output_rate: 1,
    };
}

impl Default for SessionConfig {
    fn default() -> Self {
        SessionConfig {
            first_dialect: Dialect::ColaB,
            switch_dialect: None,
            access_level: AccessLevel::AuthorizedClient,
            password: None,
            output_range: None,
            scan_data: Self::CAPTURE_SCAN_DATA,
            scan_config: None,
            echo_filter: None,
            timeouts: Timeouts::default(),
            max_failed_attempts: None,
        }
    }
}
