//! Emulator counters.

use std::sync::Mutex;

/// What the emulator did since it started.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct EmulatorStats {
    /// Connections accepted (or streams served); refused ones not included.
    pub connections: u32,
    /// Connections closed at once because [`Limits::max_connections`](crate::Limits::max_connections)
    /// were open (or no thread could be started for them).
    pub refused_connections: u32,
    /// Connections closed after [`Limits::idle_timeout`](crate::Limits::idle_timeout) without
    /// a byte from the client while not streaming.
    pub idle_closed: u32,
    /// Half-sent telegrams dropped after [`Limits::partial_frame_timeout`](crate::Limits::partial_frame_timeout).
    pub partial_frames_dropped: u64,
    /// Good frames received.
    pub frames_in: u64,
    /// Frames ignored because they were in the dialect the connection does not speak.
    pub foreign_dialect_frames: u64,
    /// Requests understood.
    pub requests: u64,
    /// `sFA` answers sent.
    pub errors_sent: u64,
    /// Scans sent (streamed and polled).
    pub scans_sent: u64,
    /// Recorded events (`sSN` other than scans) sent to subscribers.
    pub events_sent: u64,
    /// Connections dropped by fault injection.
    pub drops: u32,
    /// Garbage bursts injected.
    pub garbage_injections: u64,
    /// Scan frames damaged on purpose.
    pub corrupted_scans: u64,
    /// Answers or scans that could not be encoded (a bug: report it).
    pub emit_failures: u64,
}

/// Counters shared by the emulator's threads.
#[derive(Debug, Default)]
pub(crate) struct StatsCell(Mutex<EmulatorStats>);

impl StatsCell {
    /// Updates the counters.
    pub(crate) fn count(&self, f: impl FnOnce(&mut EmulatorStats)) {
        f(&mut self.0.lock().unwrap_or_else(|p| p.into_inner()));
    }

    /// A copy of the counters.
    pub(crate) fn snapshot(&self) -> EmulatorStats {
        *self.0.lock().unwrap_or_else(|p| p.into_inner())
    }
}
