//! Session counters.

/// What the session did since it was created. Frame-level counts (garbage, bad checksums, …)
/// are in [`crate::FramerStats`] ([`super::Session::framer_stats`]).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct SessionStats {
    /// Transport opens tried (first connect and re-connects).
    pub connect_attempts: u32,
    /// Transport opens that succeeded.
    pub connects: u32,
    /// Attempts that ended in an error (each followed by a re-connect or by giving up).
    pub failures: u32,
    /// Times the start-up sequence completed and streaming began.
    pub streams_started: u32,
    /// Scans delivered.
    pub scans: u64,
    /// Scan telegrams that failed to decode (dropped, stream goes on).
    pub bad_scans: u64,
    /// Good frames that were not the awaited answer (late answers, scans during start-up,
    /// other events): skipped.
    pub ignored_frames: u64,
    /// `sFA` answers, solicited or not.
    pub sensor_errors: u64,
    /// `SCdevicestate` answers that were busy or error.
    pub not_ready_answers: u32,
    /// Waits that ended in a time-out (probe, answer, ready, scan).
    pub timeouts: u32,
}
