//! The LMS5xx session: start-up sequence, readiness wait, scan stream, re-connect — as a
//! poll-driven state machine that never blocks without bound (`no_std`, no heap).
//!
//! ```text
//! Disconnected ──connect──▶ Probe(dialect) ──no answer──▶ Probe(other dialect) ──no answer──▶ fail
//!                               │ SCdevicestate error ──▶ WaitReady (poll until ready / time-out)
//!                               ▼ ready, or busy (0: starting up or in configuration mode, as
//!                                 SICK's driver does: log in and start the measurement; a
//!                                 step refused with sFA 13 "busy" ──▶ WaitReady, then again)
//!   Login [→ sWN EIHstCola → re-connect, if switch_dialect asks for the other dialect]
//!   → FirmwareVersion → SCdevicestate → LocationName → [sWN LMPoutputRange] → LMPoutputRange
//!   → sWN LMDscandatacfg → LMDscandatacfg → [mLMPsetscancfg → LMPscancfg] → [FREchoFilter]
//!   → LMCstartmeas → Run → sEN LMDscandata 1 ──▶ Streaming ──no scan for scan_ms──▶ fail
//! fail ──▶ close, wait reconnect_delay_ms ──▶ Disconnected (or Failed after max_failed_attempts)
//! ```
//!
//! Use: create a [`Session`] over a receive buffer (16 KiB holds an LMS511 scan in either
//! dialect), then call [`Session::poll`] in a loop with the transport and a clock. Each call does
//! a bounded amount of work (at most one connect, one probe/request write, a few reads, one frame)
//! and returns one [`Event`]; scans come as [`Event::Scan`] borrowing the receive buffer.
//!
//! ```no_run
//! # #[cfg(feature = "std")] {
//! use lidar_driver::session::{Event, Session, SessionConfig};
//! use lidar_driver::transport::{TcpConfig, TcpLink};
//! use lidar_driver::clock::StdClock;
//! let mut link = TcpLink::new("192.168.0.1:2112", TcpConfig::default()).unwrap();
//! let mut session = Session::new(vec![0u8; 16 * 1024], SessionConfig::default());
//! let clock = StdClock::new();
//! loop {
//!     match session.poll(&mut link, &clock) {
//!         Event::Scan(scan) => println!("scan {}", scan.header.scan_counter),
//!         Event::Failed(e) => panic!("{e}"),
//!         Event::Idle => {}
//!         other => println!("{other:?}"),
//!     }
//! }
//! # }
//! ```
//!
//! Frames that are not the awaited answer (late answers, garbage, other events) are skipped and
//! counted; damaged frames are dropped by the framer without losing the good ones around them.

mod config;
mod error;
mod event;
mod stats;
mod step;

pub use config::{SessionConfig, Timeouts};
pub use error::{IoOp, SessionError};
pub use event::{DeviceInfo, Event};
pub use stats::SessionStats;
pub use step::Step;

use embedded_io::Error as _;

use crate::answer::{Answer, DeviceState};
use crate::clock::Clock;
use crate::frame::{Dialect, Frame};
use crate::framer::{Framer, FramerStats};
use crate::request::names;
use crate::scandata::ScanData;
use crate::sopas_error::SopasError;
use crate::telegram::{CommandType, Telegram};
use crate::transport::Transport;

/// Transmit buffer for requests, bytes (the longest, `mLMPsetscancfg` in CoLa-A, is ~50).
const TX_LEN: usize = 128;
/// Bytes moved from the transport per read call.
const READ_CHUNK: usize = 1024;
/// Read calls per poll at most (bounds the work of one poll; 8 KiB, a CoLa-A scan).
const READS_PER_POLL: usize = 8;

/// Where the session is, for status displays.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Phase {
    /// Not connected (waiting for the first connect or the re-connect delay).
    Disconnected,
    /// Sent the dialect probe, waiting for an answer.
    Probing(Dialect),
    /// The device reported busy / error; polling it.
    WaitingForDevice(DeviceState),
    /// Running this start-up step.
    StartingUp(Step),
    /// Scans are streaming.
    Streaming,
    /// Gave up.
    Failed,
    /// Stopped by [`Session::stop`].
    Stopped,
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum State {
    Disconnected {
        retry_at_ms: u64,
    },
    Probe {
        dialect: Dialect,
        sent_ms: u64,
        other_tried: bool,
    },
    WaitReady {
        since_ms: u64,
        last: DeviceState,
        sent_ms: Option<u64>,
        next_poll_ms: u64,
    },
    Step {
        step: Step,
        sent_ms: u64,
    },
    Streaming {
        last_scan_ms: u64,
        /// No scan yet since the subscription.
        first: bool,
    },
    Failed(SessionError),
    Stopped,
}

/// A session with one LMS5xx over a [`Transport`], its receive buffer `B`
/// (`[u8; N]`, `&mut [u8]`, `Vec<u8>`) and its configuration.
#[derive(Debug)]
pub struct Session<B> {
    framer: Framer<B>,
    core: Core,
}

/// Everything but the receive buffer, so a frame borrowed from the framer can be handled while
/// the state changes.
#[derive(Debug)]
struct Core {
    cfg: SessionConfig,
    state: State,
    dialect: Dialect,
    detected: bool,
    switch_tried: bool,
    framed_last_poll: bool,
    stats: SessionStats,
    failed_attempts: u32,
    clear_framer: bool,
    /// Since when the device has said it is busy (`SCdevicestate 0`, `sFA 13`), ms; reset
    /// when the scans stream or the attempt fails.
    busy_since_ms: Option<u64>,
    pending: Option<Event<'static>>,
    tx: [u8; TX_LEN],
}

impl<B: AsRef<[u8]> + AsMut<[u8]>> Session<B> {
    /// A disconnected session; the first [`Session::poll`] connects.
    pub fn new(buf: B, cfg: SessionConfig) -> Self {
        Session {
            framer: Framer::new(buf),
            core: Core {
                cfg,
                state: State::Disconnected { retry_at_ms: 0 },
                dialect: cfg.first_dialect,
                detected: false,
                switch_tried: false,
                framed_last_poll: false,
                stats: SessionStats::default(),
                failed_attempts: 0,
                clear_framer: false,
                busy_since_ms: None,
                pending: None,
                tx: [0u8; TX_LEN],
            },
        }
    }

    /// Advances the session by a bounded amount of work and reports what happened.
    ///
    /// Never blocks beyond the transport's bounded waits (connect time-out, `read_ready` wait,
    /// write time-out). Call it in a loop; on [`Event::Idle`] the caller may sleep briefly.
    pub fn poll<T: Transport>(&mut self, io: &mut T, clock: &impl Clock) -> Event<'_> {
        let now = clock.now_ms();
        self.apply_clear();
        if let Some(ev) = self.core.pending.take() {
            return ev;
        }
        if let Some(ev) = self.core.drive(io, now) {
            self.apply_clear();
            return ev;
        }
        self.apply_clear();
        // After a frame, more may be buffered: frame them before waiting on the transport
        // (whose `read_ready` may wait a few ms), so a burst is delivered without delay.
        let frames_pending = self.core.framed_last_poll && self.framer.buffered() > 0;
        if !frames_pending {
            if let Err(ev) = self.core.fill(&mut self.framer, io, now) {
                self.apply_clear();
                return ev;
            }
        }
        let next = self.framer.next_frame();
        self.core.framed_last_poll = next.is_some();
        match next {
            None => Event::Idle,
            Some(Err(e)) => Event::FrameDropped(e),
            Some(Ok(frame)) => self.core.on_frame(frame, io, now),
        }
    }

    /// Ends the session politely: while scans stream, sends `sEN LMDscandata 0` (best effort,
    /// the answer is not awaited), then closes the transport. Later polls return
    /// [`Event::Idle`] until [`Session::restart`].
    pub fn stop<T: Transport>(&mut self, io: &mut T) {
        if matches!(self.core.state, State::Streaming { .. }) {
            let unsubscribe = crate::request::Request::Subscribe {
                event: names::SCAN_DATA,
                enable: false,
            };
            if let Ok(n) = unsubscribe.emit(self.core.dialect, &mut self.core.tx) {
                let bytes = self.core.tx.get(..n).unwrap_or(&[]);
                let _ = io.write_all(bytes).and_then(|()| io.flush());
            }
        }
        io.close();
        self.core.state = State::Stopped;
        self.core.pending = None;
        self.framer.clear();
    }

    /// Starts over after [`Event::Failed`] (or at any time): closes nothing itself; the next
    /// poll re-connects. Counters are kept.
    pub fn restart(&mut self) {
        self.core.state = State::Disconnected { retry_at_ms: 0 };
        self.core.failed_attempts = 0;
        self.core.switch_tried = false;
        self.core.pending = None;
        self.framer.clear();
    }

    /// Where the session is.
    pub fn phase(&self) -> Phase {
        match self.core.state {
            State::Disconnected { .. } => Phase::Disconnected,
            State::Probe { dialect, .. } => Phase::Probing(dialect),
            State::WaitReady { last, .. } => Phase::WaitingForDevice(last),
            State::Step { step, .. } => Phase::StartingUp(step),
            State::Streaming { .. } => Phase::Streaming,
            State::Failed(_) => Phase::Failed,
            State::Stopped => Phase::Stopped,
        }
    }

    /// The dialect the sensor answered in, once detected.
    pub fn dialect(&self) -> Option<Dialect> {
        self.core.detected.then_some(self.core.dialect)
    }

    /// Session counters.
    pub fn stats(&self) -> &SessionStats {
        &self.core.stats
    }

    /// Frame counters (bytes, good frames per dialect, drops by cause) since creation.
    pub fn framer_stats(&self) -> &FramerStats {
        self.framer.stats()
    }

    /// The configuration.
    pub fn config(&self) -> &SessionConfig {
        &self.core.cfg
    }

    fn apply_clear(&mut self) {
        if self.core.clear_framer {
            self.core.clear_framer = false;
            self.framer.clear();
        }
    }
}

fn elapsed(now: u64, since: u64) -> u64 {
    now.saturating_sub(since)
}

fn other(d: Dialect) -> Dialect {
    match d {
        Dialect::ColaA => Dialect::ColaB,
        Dialect::ColaB => Dialect::ColaA,
    }
}

fn io_error(op: IoOp, e: &impl embedded_io::Error) -> SessionError {
    SessionError::Transport { op, kind: e.kind() }
}

/// Read errors that only mean "no data yet".
fn no_data(kind: embedded_io::ErrorKind) -> bool {
    matches!(
        kind,
        embedded_io::ErrorKind::TimedOut | embedded_io::ErrorKind::Interrupted
    )
}

fn ignored<'a>(t: &Telegram<'a>) -> Event<'a> {
    Event::Ignored {
        kind: Some(t.kind()),
        name: t.name(),
    }
}

// Helpers return the event that ends an attempt as their `Err`: it is moved once per failure,
// not per scan, so its size does not matter.
#[allow(clippy::result_large_err)]
impl Core {
    /// Time-outs and actions that do not depend on received frames. `None` = go on reading.
    fn drive<T: Transport>(&mut self, io: &mut T, now: u64) -> Option<Event<'static>> {
        let t = self.cfg.timeouts;
        match self.state {
            State::Failed(e) => Some(Event::Failed(e)),
            State::Stopped => Some(Event::Idle),
            State::Disconnected { retry_at_ms } => {
                if now < retry_at_ms {
                    return Some(Event::Idle);
                }
                self.stats.connect_attempts += 1;
                if let Err(e) = io.reconnect() {
                    return Some(self.fail(io, now, io_error(IoOp::Connect, &e)));
                }
                self.stats.connects += 1;
                self.clear_framer = true;
                let d = self.dialect;
                if let Err(e) = self.probe(io, now, d, false) {
                    return Some(e);
                }
                self.pending = Some(Event::Probing(d));
                Some(Event::Connected {
                    attempt: self.failed_attempts + 1,
                })
            }
            State::Probe {
                dialect,
                sent_ms,
                other_tried,
            } => {
                if elapsed(now, sent_ms) < t.probe_ms {
                    return None;
                }
                self.stats.timeouts += 1;
                if other_tried {
                    let e = SessionError::NoAnswer {
                        waited_ms: t.probe_ms,
                    };
                    return Some(self.fail(io, now, e));
                }
                // Re-open: the wrong-dialect bytes may have left the sensor's parser mid-frame.
                if let Err(e) = io.reconnect() {
                    return Some(self.fail(io, now, io_error(IoOp::Connect, &e)));
                }
                self.clear_framer = true;
                let d = other(dialect);
                if let Err(e) = self.probe(io, now, d, true) {
                    return Some(e);
                }
                Some(Event::Probing(d))
            }
            State::WaitReady {
                since_ms,
                last,
                sent_ms,
                next_poll_ms,
            } => {
                let waited = elapsed(now, since_ms);
                if waited >= t.ready_ms {
                    self.stats.timeouts += 1;
                    let e = SessionError::DeviceNotReady {
                        state: last,
                        waited_ms: waited,
                    };
                    return Some(self.fail(io, now, e));
                }
                match sent_ms {
                    Some(s) if elapsed(now, s) >= t.answer_ms => {
                        self.stats.timeouts += 1;
                        let e = SessionError::Timeout {
                            step: Step::WaitReady,
                            waited_ms: elapsed(now, s),
                        };
                        Some(self.fail(io, now, e))
                    }
                    None if now >= next_poll_ms => {
                        if let Err(e) = self.send(io, Step::WaitReady, self.dialect) {
                            return Some(self.fail(io, now, e));
                        }
                        self.state = State::WaitReady {
                            since_ms,
                            last,
                            sent_ms: Some(now),
                            next_poll_ms,
                        };
                        None
                    }
                    _ => None,
                }
            }
            State::Step { step, sent_ms } => {
                let waited = elapsed(now, sent_ms);
                if waited < t.answer_ms {
                    return None;
                }
                self.stats.timeouts += 1;
                Some(self.fail(
                    io,
                    now,
                    SessionError::Timeout {
                        step,
                        waited_ms: waited,
                    },
                ))
            }
            State::Streaming {
                last_scan_ms,
                first,
            } => {
                let waited = elapsed(now, last_scan_ms);
                if waited < if first { t.first_scan_ms } else { t.scan_ms } {
                    return None;
                }
                self.stats.timeouts += 1;
                let e = SessionError::ScanTimeout {
                    waited_ms: waited,
                    first,
                };
                Some(self.fail(io, now, e))
            }
        }
    }

    /// Moves available bytes from the transport into the framer (bounded: a few reads of at
    /// most [`READ_CHUNK`] bytes, never more than the framer has room for). The transport
    /// reads straight into the framer's free space: no staging buffer to clear or copy.
    fn fill<B: AsRef<[u8]> + AsMut<[u8]>, T: Transport>(
        &mut self,
        framer: &mut Framer<B>,
        io: &mut T,
        now: u64,
    ) -> Result<(), Event<'static>> {
        for _ in 0..READS_PER_POLL {
            if framer.buffered() >= framer.capacity() {
                break;
            }
            match io.read_ready() {
                Ok(true) => {}
                Ok(false) => break,
                Err(e) if no_data(e.kind()) => break,
                Err(e) => return Err(self.fail(io, now, io_error(IoOp::Read, &e))),
            }
            let spare = framer.spare_mut(READ_CHUNK);
            let n = spare.len().min(READ_CHUNK);
            // (Never read into nothing: a read of 0 bytes means the peer closed.)
            let Some(dst) = spare.get_mut(..n).filter(|d| !d.is_empty()) else {
                break;
            };
            match io.read(dst) {
                Ok(0) => return Err(self.fail(io, now, SessionError::ConnectionClosed)),
                Ok(k) => framer.commit(k),
                Err(e) if no_data(e.kind()) => break,
                Err(e) => return Err(self.fail(io, now, io_error(IoOp::Read, &e))),
            }
        }
        Ok(())
    }

    /// Ends the attempt: closes the link, counts, and schedules the re-connect (or gives up).
    /// Sends the dialect probe in `dialect` and waits for its answer (`other_tried`: the
    /// other dialect was probed already); a failed send is the failure event.
    fn probe<T: Transport>(
        &mut self,
        io: &mut T,
        now: u64,
        dialect: Dialect,
        other_tried: bool,
    ) -> Result<(), Event<'static>> {
        if let Err(e) = self.send(io, Step::Probe, dialect) {
            return Err(self.fail(io, now, e));
        }
        self.state = State::Probe {
            dialect,
            sent_ms: now,
            other_tried,
        };
        Ok(())
    }

    /// A start-up step was refused with "server busy" (`sFA 13`): the device is still booting.
    /// Poll `SCdevicestate` after the poll interval and start up again, until the ready
    /// time-out counted from the first busy answer.
    fn wait_while_busy(&mut self, now: u64) -> Event<'static> {
        self.stats.not_ready_answers += 1;
        let since_ms = *self.busy_since_ms.get_or_insert(now);
        self.state = State::WaitReady {
            since_ms,
            last: DeviceState::Busy,
            sent_ms: None,
            next_poll_ms: now.saturating_add(self.cfg.timeouts.ready_poll_ms),
        };
        Event::DeviceNotReady {
            state: DeviceState::Busy,
            waited_ms: elapsed(now, since_ms),
        }
    }

    fn fail<T: Transport>(&mut self, io: &mut T, now: u64, error: SessionError) -> Event<'static> {
        io.close();
        self.clear_framer = true;
        self.busy_since_ms = None;
        self.pending = None;
        self.stats.failures += 1;
        self.failed_attempts = self.failed_attempts.saturating_add(1);
        if let Some(max) = self.cfg.max_failed_attempts {
            if self.failed_attempts >= max {
                self.state = State::Failed(error);
                return Event::Failed(error);
            }
        }
        let delay = self.cfg.timeouts.reconnect_delay_ms;
        self.state = State::Disconnected {
            retry_at_ms: now.saturating_add(delay),
        };
        Event::Reconnecting {
            error,
            failed_attempts: self.failed_attempts,
            retry_in_ms: delay,
        }
    }

    fn send<T: Transport>(
        &mut self,
        io: &mut T,
        step: Step,
        dialect: Dialect,
    ) -> Result<(), SessionError> {
        let n = step
            .request(&self.cfg)
            .emit(dialect, &mut self.tx)
            .map_err(SessionError::Emit)?;
        let bytes = self.tx.get(..n).unwrap_or(&[]);
        io.write_all(bytes)
            .and_then(|()| io.flush())
            .map_err(|e| io_error(IoOp::Write, &e))
    }

    /// Sends `step`'s request and waits for its answer; a send failure ends the attempt.
    fn start_step<T: Transport>(
        &mut self,
        io: &mut T,
        now: u64,
        step: Step,
    ) -> Result<(), Event<'static>> {
        match self.send(io, step, self.dialect) {
            Ok(()) => {
                self.state = State::Step { step, sent_ms: now };
                Ok(())
            }
            Err(e) => Err(self.fail(io, now, e)),
        }
    }

    fn on_frame<'a, T: Transport>(&mut self, frame: Frame<'a>, io: &mut T, now: u64) -> Event<'a> {
        let t = match Telegram::parse(frame) {
            Ok(t) => t,
            Err(_) => {
                self.stats.ignored_frames += 1;
                return Event::Ignored {
                    kind: None,
                    name: "",
                };
            }
        };
        if t.kind() == CommandType::Error {
            self.stats.sensor_errors += 1;
        }
        match self.state {
            State::Streaming { .. } => self.on_stream_frame(&t, now),
            State::Probe { .. } | State::WaitReady { .. } => self.on_probe_frame(&t, io, now),
            State::Step { step, .. } => self.on_step_frame(&t, io, now, step),
            State::Disconnected { .. } | State::Failed(_) | State::Stopped => {
                self.stats.ignored_frames += 1;
                ignored(&t)
            }
        }
    }

    fn on_stream_frame<'a>(&mut self, t: &Telegram<'a>, now: u64) -> Event<'a> {
        if ScanData::is_scan_telegram(t) {
            return match ScanData::from_telegram(t) {
                Ok(scan) => {
                    self.state = State::Streaming {
                        last_scan_ms: now,
                        first: false,
                    };
                    self.stats.scans += 1;
                    self.failed_attempts = 0;
                    Event::Scan(scan)
                }
                Err(e) => {
                    self.stats.bad_scans += 1;
                    Event::BadScan(e)
                }
            };
        }
        if let Ok(Answer::Error(e)) = Answer::parse(t) {
            return Event::SensorError(e);
        }
        self.stats.ignored_frames += 1;
        ignored(t)
    }

    /// Probe and ready wait: the `SCdevicestate` answer (or an `sFA`) tells the dialect.
    fn on_probe_frame<'a, T: Transport>(
        &mut self,
        t: &Telegram<'a>,
        io: &mut T,
        now: u64,
    ) -> Event<'a> {
        let probing = match self.state {
            State::Probe { dialect, .. } => Some(dialect),
            _ => None,
        };
        let step = if probing.is_some() {
            Step::Probe
        } else {
            Step::WaitReady
        };
        if t.kind() == CommandType::Error {
            let error = match Answer::parse(t) {
                Ok(Answer::Error(e)) => e,
                _ => crate::sopas_error::SopasError::Other(0),
            };
            return match probing {
                // The sensor answered in its own dialect: it speaks that one.
                Some(sent) if sent != t.dialect() => {
                    self.detect(t.dialect());
                    if let Err(ev) = self.start_probe_again(io, now) {
                        return ev;
                    }
                    Event::DialectDetected(t.dialect())
                }
                // Some firmware refuses SCdevicestate before login: it answered, so go on.
                Some(_) => {
                    self.detect(t.dialect());
                    match self.start_step(io, now, Step::FIRST_AFTER_PROBE) {
                        Ok(()) => Event::DialectDetected(t.dialect()),
                        Err(ev) => ev,
                    }
                }
                None => self.fail(io, now, SessionError::Refused { step, error }),
            };
        }
        if !(t.kind() == CommandType::ReadAnswer && t.name() == names::DEVICE_STATE) {
            self.stats.ignored_frames += 1;
            return ignored(t);
        }
        let state = match Answer::parse(t) {
            Ok(Answer::DeviceState(s)) => s,
            Ok(_) => return ignored(t),
            Err(error) => return self.fail(io, now, SessionError::BadAnswer { step, error }),
        };
        self.detect(t.dialect());
        let detected = Event::DialectDetected(t.dialect());
        if state == DeviceState::Busy {
            self.stats.not_ready_answers += 1;
            let since_ms = *self.busy_since_ms.get_or_insert(now);
            let busy = Event::DeviceNotReady {
                state,
                waited_ms: elapsed(now, since_ms),
            };
            if let Err(ev) = self.start_step(io, now, Step::FIRST_AFTER_PROBE) {
                return ev;
            }
            if probing.is_some() {
                self.pending = Some(busy);
                return detected;
            }
            return busy;
        }
        if state == DeviceState::Ready {
            return match self.start_step(io, now, Step::FIRST_AFTER_PROBE) {
                Ok(()) if probing.is_some() => detected,
                Ok(()) => Event::Info(event::DeviceInfo::DeviceState(state)),
                Err(ev) => ev,
            };
        }
        self.stats.not_ready_answers += 1;
        let since_ms = match self.state {
            State::WaitReady { since_ms, .. } => since_ms,
            _ => now,
        };
        self.state = State::WaitReady {
            since_ms,
            last: state,
            sent_ms: None,
            next_poll_ms: now.saturating_add(self.cfg.timeouts.ready_poll_ms),
        };
        let not_ready = Event::DeviceNotReady {
            state,
            waited_ms: elapsed(now, since_ms),
        };
        if probing.is_some() {
            self.pending = Some(not_ready);
            detected
        } else {
            not_ready
        }
    }

    fn detect(&mut self, d: Dialect) {
        self.dialect = d;
        self.detected = true;
    }

    fn start_probe_again<T: Transport>(
        &mut self,
        io: &mut T,
        now: u64,
    ) -> Result<(), Event<'static>> {
        if let Err(e) = self.send(io, Step::Probe, self.dialect) {
            return Err(self.fail(io, now, e));
        }
        self.state = State::Probe {
            dialect: self.dialect,
            sent_ms: now,
            other_tried: true,
        };
        Ok(())
    }

    fn on_step_frame<'a, T: Transport>(
        &mut self,
        t: &Telegram<'a>,
        io: &mut T,
        now: u64,
        step: Step,
    ) -> Event<'a> {
        let (kind, name) = step.expected_answer(&self.cfg);
        if t.kind() == CommandType::Error {
            return match Answer::parse(t) {
                // Still booting: wait for the device, then start up again.
                Ok(Answer::Error(SopasError::ServerBusy)) => self.wait_while_busy(now),
                Ok(Answer::Error(error)) => {
                    self.fail(io, now, SessionError::Refused { step, error })
                }
                Ok(_) => ignored(t),
                Err(error) => self.fail(io, now, SessionError::BadAnswer { step, error }),
            };
        }
        if t.kind() == CommandType::MethodAccepted && t.name() == name {
            // `sMA`: accepted, the `sAN` follows; the answer time-out restarts.
            self.state = State::Step { step, sent_ms: now };
            return Event::Idle;
        }
        if t.kind() != kind || t.name() != name {
            self.stats.ignored_frames += 1;
            return ignored(t);
        }
        let answer = match Answer::parse(t) {
            Ok(a) => a,
            Err(error) => return self.fail(io, now, SessionError::BadAnswer { step, error }),
        };
        let ev = match self.accept(step, answer) {
            Ok(ev) => ev,
            Err(e) => return self.fail(io, now, e),
        };
        if step == Step::SwitchDialect {
            // Effective on a new connection: re-connect now, probe the new dialect first.
            let to = self.cfg.switch_dialect.unwrap_or(self.dialect);
            io.close();
            self.clear_framer = true;
            self.dialect = to;
            self.detected = false;
            self.state = State::Disconnected { retry_at_ms: now };
            return Event::DialectSwitched(to);
        }
        let switch = self.cfg.switch_dialect.filter(|&d| d != self.dialect);
        if step == Step::Login && switch.is_some() && !self.switch_tried {
            self.switch_tried = true;
            return match self.start_step(io, now, Step::SwitchDialect) {
                Ok(()) => ev,
                Err(fail) => fail,
            };
        }
        match step.next(&self.cfg) {
            Some(next) => {
                if let Err(ev) = self.start_step(io, now, next) {
                    return ev;
                }
            }
            None => {
                self.state = State::Streaming {
                    last_scan_ms: now,
                    first: true,
                };
                self.busy_since_ms = None;
                self.stats.streams_started += 1;
            }
        }
        ev
    }

    /// Checks a step's typed answer; the event to report, or why the start-up failed.
    fn accept<'a>(&self, step: Step, a: Answer<'a>) -> Result<Event<'a>, SessionError> {
        use event::DeviceInfo as I;
        let cfg = &self.cfg;
        Ok(match a {
            Answer::AccessMode { accepted } => {
                if !accepted {
                    return Err(SessionError::LoginRefused {
                        level: cfg.access_level.level(),
                    });
                }
                Event::StepDone(step)
            }
            Answer::FirmwareVersion(v) => Event::Info(I::FirmwareVersion(v)),
            Answer::DeviceState(DeviceState::Error) => {
                return Err(SessionError::DeviceNotReady {
                    state: DeviceState::Error,
                    waited_ms: 0,
                })
            }
            // Busy here is normal: the LMS511 reports 0 in configuration mode (capture).
            Answer::DeviceState(s) => Event::Info(I::DeviceState(s)),
            Answer::LocationName(v) => Event::Info(I::LocationName(v)),
            Answer::OutputRange(r) => {
                if cfg.output_range.is_some_and(|want| want != r) {
                    return Err(SessionError::OutputRangeNotApplied);
                }
                Event::Info(I::OutputRange(r))
            }
            Answer::ScanDataConfig(c) => Event::Info(I::ScanDataConfig(c)),
            Answer::SetScanConfig { result, .. } => {
                result.map_err(SessionError::ScanConfigRefused)?;
                Event::StepDone(step)
            }
            Answer::ScanConfig(actual) => {
                if let Some(requested) = cfg.scan_config {
                    if requested.frequency_1e2_hz != actual.frequency_1e2_hz
                        || requested.step_1e4_deg != actual.step_1e4_deg
                    {
                        return Err(SessionError::ScanConfigNotApplied { requested, actual });
                    }
                }
                Event::Info(I::ScanConfig(actual))
            }
            Answer::StartMeasurement { ok } => {
                if !ok {
                    return Err(SessionError::StartMeasurementFailed);
                }
                Event::StepDone(step)
            }
            Answer::Run { ok } => {
                if !ok {
                    return Err(SessionError::RunFailed);
                }
                Event::StepDone(step)
            }
            Answer::EventAck { enabled, .. } => {
                if !enabled {
                    return Err(SessionError::SubscribeRefused);
                }
                Event::Streaming
            }
            _ => Event::StepDone(step),
        })
    }
}

#[cfg(all(test, feature = "std"))]
mod tests;
