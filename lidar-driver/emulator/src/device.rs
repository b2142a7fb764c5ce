//! The emulated device's protocol logic for one connection: requests in, answers and scans
//! out (no I/O here; [`crate::serve`] moves the bytes).

use std::time::{Duration, Instant};

use lidar_driver::answer::{Answer, DeviceState};
use lidar_driver::args::{ArgErrorKind, TelegramWriter};
use lidar_driver::frame::{Dialect, Frame};
use lidar_driver::request::{names, AccessLevel, EchoFilter, Request, RequestError, ScanConfig};
use lidar_driver::sopas_error::SopasError;
use lidar_driver::telegram::{CommandType, Telegram};
use lidar_driver::ScanRepr;

use crate::config::{DialectMode, EmulatorConfig};
use crate::recorded::RecordedTelegram;
use crate::Shared;

/// A subscription to a recorded event (`LIDoutputstate`, `LFErec`, …): its recorded events
/// go out at their recorded times after the acknowledgement, once each.
#[derive(Debug, Clone, PartialEq)]
struct EventSubscription {
    name: String,
    since: Instant,
    sent: usize,
}

/// The LMS5xx's scan frequencies, 1/100 Hz (its operating instructions, `mLMPsetscancfg`).
pub(crate) const LMS5XX_FREQUENCIES_1E2_HZ: [u32; 5] = [2500, 3500, 5000, 7500, 10000];

/// The LMS5xx's angular resolutions, 1/10000° (the same table).
pub(crate) const LMS5XX_STEPS_1E4_DEG: [u32; 7] = [1667, 2500, 3333, 5000, 6667, 7500, 10000];

/// Most shots per second, 100 Hz units: the LMS5xx fires at 54 kHz, so a frequency and a
/// resolution go together when `f · 360° / step` fits (25 Hz takes every resolution down to
/// 0.1667°, 35 Hz down to 0.25°, 50 Hz 0.3333°, 75 Hz 0.5°, 100 Hz 0.6667°).
const LMS5XX_MAX_SHOTS_100HZ: u32 = 540;

/// Shots per second of a frequency and resolution, 100 Hz units (rounded).
pub(crate) fn shots_100hz(frequency_1e2_hz: u32, step_1e4_deg: u32) -> u32 {
    let s = u64::from(frequency_1e2_hz) * 360;
    ((s + u64::from(step_1e4_deg) / 2) / u64::from(step_1e4_deg.max(1))) as u32
}

/// Settings that outlive a connection (the device keeps them until power-off).
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Settings {
    pub(crate) output_range: lidar_driver::request::OutputRange,
    pub(crate) scan_data: lidar_driver::request::ScanDataConfig,
    pub(crate) scan_config: ScanConfig,
    pub(crate) echo_filter: EchoFilter,
    /// `EIHstCola` written: applies to the next connections (with [`DialectMode::Only`]).
    pub(crate) host_dialect: Option<Dialect>,
    /// Scans sent since power-up (counters of restamped scans).
    pub(crate) scans_sent: u64,
}

impl Settings {
    pub(crate) fn new(cfg: &EmulatorConfig) -> Self {
        let mut scan_config = cfg.identity.scan_config;
        scan_config.frequency_1e2_hz = (cfg.rate_hz * 100.0).round().max(1.0) as u32;
        Settings {
            output_range: cfg.identity.output_range,
            scan_data: cfg.identity.scan_data,
            scan_config,
            echo_filter: EchoFilter::First,
            host_dialect: None,
            scans_sent: 0,
        }
    }
}

/// What the connection loop must do after handling input.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Verdict {
    /// Go on.
    Continue,
    /// Close the connection (fault injection).
    Drop,
}

/// One client connection's protocol state.
pub(crate) struct Connection<'s> {
    shared: &'s Shared,
    dialect: Option<Dialect>,
    level: u8,
    config_mode: bool,
    subscribed: bool,
    events: Vec<EventSubscription>,
    next_scan: Option<Instant>,
    scans_here: u64,
    verdict: Verdict,
    tx: Vec<u8>,
}

impl<'s> Connection<'s> {
    pub(crate) fn new(shared: &'s Shared) -> Self {
        let dialect = match shared.config.dialect {
            DialectMode::Auto => None,
            DialectMode::Only(d) => Some(shared.settings().host_dialect.unwrap_or(d)),
        };
        Connection {
            shared,
            dialect,
            level: 0,
            config_mode: false,
            subscribed: false,
            events: Vec::new(),
            next_scan: None,
            scans_here: 0,
            verdict: Verdict::Continue,
            tx: vec![0u8; 512],
        }
    }

    fn booting(&self, now: Instant) -> bool {
        now.duration_since(self.shared.started) < self.shared.config.startup_delay
    }

    /// Handles one received frame, appending any answer to `out`.
    pub(crate) fn on_frame(&mut self, frame: Frame<'_>, now: Instant, out: &mut Vec<u8>) {
        self.shared.stats.count(|s| s.frames_in += 1);
        if self.shared.config.faults.silent {
            return;
        }
        let d = frame.dialect();
        match self.dialect {
            None => self.dialect = Some(d),
            Some(own) if own != d => {
                // A real device does not understand the other dialect: no answer.
                self.shared.stats.count(|s| s.foreign_dialect_frames += 1);
                return;
            }
            Some(_) => {}
        }
        let answer = match Telegram::parse(frame) {
            Ok(t) => self.answer(&t, now),
            Err(_) => Reply::Error(SopasError::UnknownColaCommand),
        };
        self.write_reply(d, answer, out);
    }

    fn write_reply(&mut self, d: Dialect, reply: Reply<'_>, out: &mut Vec<u8>) {
        let n = match reply {
            Reply::Answer(a) => a.emit(d, &mut self.tx),
            Reply::Error(e) => {
                self.shared.stats.count(|s| s.errors_sent += 1);
                Answer::Error(e).emit(d, &mut self.tx)
            }
            Reply::EventAck(event, enabled) => Answer::EventAck {
                event: &event,
                enabled,
            }
            .emit(d, &mut self.tx),
            Reply::EchoFilter(f) => {
                TelegramWriter::begin(d, &mut self.tx, CommandType::ReadAnswer, names::ECHO_FILTER)
                    .and_then(|mut w| {
                        w.u8(match f {
                            EchoFilter::First => 0,
                            EchoFilter::All => 1,
                            EchoFilter::Last => 2,
                        })?;
                        w.finish()
                    })
            }
            Reply::Scan(scan) => {
                match scan.to_vec(d) {
                    Ok(v) => out.extend_from_slice(&v),
                    Err(_) => self.shared.stats.count(|s| s.emit_failures += 1),
                }
                return;
            }
            Reply::Recorded(t) => {
                match t.for_dialect(d) {
                    Some(v) => out.extend_from_slice(&v),
                    None => self.shared.stats.count(|s| s.emit_failures += 1),
                }
                return;
            }
            Reply::None => return,
        };
        match n {
            Ok(n) => out.extend_from_slice(&self.tx[..n]),
            Err(_) => self.shared.stats.count(|s| s.emit_failures += 1),
        }
    }

    fn answer(&mut self, t: &Telegram<'_>, now: Instant) -> Reply<'s> {
        let req = match Request::parse(t) {
            Ok(r) => r,
            // Not modelled here: what the recorded sensor answered, if it was asked.
            Err(RequestError::Unsupported(kind)) if self.recorded(kind, t.name()).is_some() => {
                return match self.recorded(kind, t.name()) {
                    Some(r) if !self.booting(now) => Reply::Recorded(r),
                    _ => Reply::Error(SopasError::ServerBusy),
                };
            }
            Err(RequestError::Unsupported(CommandType::WriteRequest)) => {
                return Reply::Error(SopasError::UnknownVariable)
            }
            Err(RequestError::Unsupported(CommandType::MethodRequest)) => {
                return Reply::Error(SopasError::UnknownMethod)
            }
            Err(RequestError::Unsupported(_)) | Err(RequestError::Telegram(_)) => {
                return Reply::Error(SopasError::UnknownColaCommand)
            }
            Err(RequestError::Args(e)) => {
                return Reply::Error(match (t.dialect(), e.kind) {
                    (_, ArgErrorKind::Truncated) => SopasError::BufferUnderflow,
                    (_, ArgErrorKind::TrailingData) => SopasError::BufferOverflow,
                    (Dialect::ColaA, ArgErrorKind::OutOfRange) => SopasError::ColaAValueOverflow,
                    (Dialect::ColaA, ArgErrorKind::InvalidNumber | ArgErrorKind::BadText) => {
                        SopasError::ColaAInvalidCharacter
                    }
                    _ => SopasError::InvalidData,
                })
            }
            // A request the parser cannot tell apart is data the device would not accept.
            Err(_) => return Reply::Error(SopasError::InvalidData),
        };
        self.shared.stats.count(|s| s.requests += 1);
        let booting = self.booting(now);
        if let Request::Read(name) = req {
            return self.read(name, booting, now);
        }
        if booting {
            return Reply::Error(SopasError::ServerBusy);
        }
        let authorized = self.level >= AccessLevel::AuthorizedClient.level();
        let mut st = self.shared.settings();
        match req {
            Request::SetAccessMode { level, password } => {
                let ok = [
                    AccessLevel::Maintenance,
                    AccessLevel::AuthorizedClient,
                    AccessLevel::Service,
                ]
                .iter()
                .any(|l| l.level() == level && l.default_password() == password);
                if ok {
                    self.level = level;
                    self.config_mode = true;
                }
                Reply::Answer(Answer::AccessMode { accepted: ok })
            }
            Request::Subscribe { event, enable } if event == names::SCAN_DATA => {
                self.subscribed = enable;
                self.next_scan = None;
                Reply::Answer(Answer::EventAck {
                    event: names::SCAN_DATA,
                    enabled: enable,
                })
            }
            Request::Subscribe { event, enable } => {
                let recorded = &self.shared.config.identity.recorded;
                if !recorded.knows_event(event) {
                    return Reply::Error(SopasError::UnknownVariable);
                }
                self.events.retain(|s| s.name != event);
                let ack = recorded.answer(CommandType::EventRequest, event);
                if !enable {
                    return Reply::EventAck(event.to_string(), false);
                }
                self.events.push(EventSubscription {
                    name: event.to_string(),
                    since: now,
                    sent: 0,
                });
                match ack {
                    Some(a) => Reply::Recorded(a),
                    None => Reply::EventAck(event.to_string(), true),
                }
            }
            // Everything below changes the device: authorized client or higher only.
            Request::Read(_) => Reply::None,
            _ if !authorized => Reply::Error(match req.header().0 {
                CommandType::WriteRequest => SopasError::WriteAccessDenied,
                _ => SopasError::AccessDenied,
            }),
            Request::SetHostDialect(d) => {
                st.host_dialect = Some(d);
                Reply::Answer(Answer::WriteAck(names::HOST_COLA))
            }
            Request::SetDo3And4Function(_) => {
                Reply::Answer(Answer::WriteAck(names::DO3_AND_4_FUNCTION))
            }
            Request::SetIncrementSource(_) => {
                Reply::Answer(Answer::WriteAck(names::INCREMENT_SOURCE))
            }
            Request::SetEncoderSetting(_) => {
                Reply::Answer(Answer::WriteAck(names::ENCODER_SETTING))
            }
            Request::SetEncoderResolution(_) => {
                Reply::Answer(Answer::WriteAck(names::ENCODER_RESOLUTION))
            }
            Request::SetOutputRange(r) => {
                let (lo, hi) = self.shared.config.identity.field_of_view_1e4_deg;
                if r.start_1e4_deg < lo || r.stop_1e4_deg > hi || r.start_1e4_deg >= r.stop_1e4_deg
                {
                    return Reply::Error(SopasError::LocalConditionFailed);
                }
                st.output_range = r;
                Reply::Answer(Answer::WriteAck(names::OUTPUT_RANGE))
            }
            Request::SetScanDataConfig(c) => {
                st.scan_data = c;
                Reply::Answer(Answer::WriteAck(names::SCAN_DATA_CONFIG))
            }
            Request::SetScanConfig(c) => {
                let r = check_scan_config(&c, self.shared.config.identity.field_of_view_1e4_deg);
                if r.is_ok() {
                    st.scan_config = c;
                    // The output range follows the new resolution and stays within the area.
                    st.output_range.step_1e4_deg = c.step_1e4_deg;
                    st.output_range.start_1e4_deg =
                        st.output_range.start_1e4_deg.max(c.start_1e4_deg);
                    st.output_range.stop_1e4_deg = st.output_range.stop_1e4_deg.min(c.stop_1e4_deg);
                    self.next_scan = None;
                }
                Reply::Answer(Answer::SetScanConfig {
                    result: r,
                    in_effect: Some(st.scan_config),
                })
            }
            Request::SetEchoFilter(f) => {
                st.echo_filter = f;
                Reply::Answer(Answer::WriteAck(names::ECHO_FILTER))
            }
            Request::StartMeasurement => Reply::Answer(Answer::StartMeasurement { ok: true }),
            Request::StopMeasurement => Reply::Answer(Answer::StopMeasurement { ok: true }),
            Request::Run => {
                self.config_mode = false;
                Reply::Answer(Answer::Run { ok: true })
            }
        }
    }

    fn read(&mut self, name: &str, booting: bool, now: Instant) -> Reply<'s> {
        let shared: &'s Shared = self.shared;
        let id = &shared.config.identity;
        if name == names::DEVICE_STATE {
            // Busy while booting; the LMS511 of the capture also answers 0 after login
            // (configuration mode) until Run.
            let s = if booting || self.config_mode {
                DeviceState::Busy
            } else {
                DeviceState::Ready
            };
            return Reply::Answer(Answer::DeviceState(s));
        }
        if booting {
            return Reply::Error(SopasError::ServerBusy);
        }
        let st = self.shared.settings().clone();
        Reply::Answer(match name {
            names::FIRMWARE_VERSION => Answer::FirmwareVersion(&id.firmware_version),
            names::LOCATION_NAME => Answer::LocationName(&id.location_name),
            names::OPERATING_HOURS => Answer::OperatingHours(id.operating_hours),
            names::POWER_ON_COUNT => Answer::PowerOnCount(id.power_on_count),
            names::OUTPUT_RANGE => Answer::OutputRange(st.output_range),
            names::SCAN_DATA_CONFIG => Answer::ScanDataConfig(st.scan_data),
            names::SCAN_CONFIG => Answer::ScanConfig(st.scan_config),
            names::ECHO_FILTER => return Reply::EchoFilter(st.echo_filter),
            names::SCAN_DATA => {
                return match self.make_scan(now, CommandType::ReadAnswer) {
                    Some(s) => Reply::Scan(s),
                    None => Reply::Error(SopasError::LocalConditionFailed),
                }
            }
            _ => {
                return match self.recorded(CommandType::ReadRequest, name) {
                    Some(r) => Reply::Recorded(r),
                    None => Reply::Error(SopasError::UnknownVariable),
                }
            }
        })
    }

    /// The recorded sensor's answer to a request of `kind` for `name`, if it was asked.
    fn recorded(&self, kind: CommandType, name: &str) -> Option<&'s RecordedTelegram> {
        let shared: &'s Shared = self.shared;
        shared.config.identity.recorded.answer(kind, name)
    }

    /// The recorded events of the subscriptions that are due by `now`, in recorded order.
    fn send_events(&mut self, d: Dialect, now: Instant, out: &mut Vec<u8>) {
        let shared: &'s Shared = self.shared;
        for sub in &mut self.events {
            let due = shared
                .config
                .identity
                .recorded
                .events(&sub.name)
                .skip(sub.sent)
                .take_while(|e| now.duration_since(sub.since) >= e.after);
            for e in due {
                if let Some(v) = e.telegram.for_dialect(d) {
                    out.extend_from_slice(&v);
                    shared.stats.count(|s| s.events_sent += 1);
                }
                sub.sent += 1;
            }
        }
    }

    /// Whether scans are streamed to this connection (subscribed, not in configuration
    /// mode, not a silent device): such a connection is never idle.
    pub(crate) fn streaming(&self) -> bool {
        self.subscribed && !self.config_mode && !self.shared.config.faults.silent
    }

    /// When [`Connection::tick`] has something to send next (a scan, a recorded event), if
    /// anything: the connection loop sleeps until then.
    pub(crate) fn next_due(&self, now: Instant) -> Option<Instant> {
        self.dialect?;
        let shared = self.shared;
        let mut due: Option<Instant> = None;
        let mut at = |t: Instant| due = Some(due.map_or(t, |d| d.min(t)));
        if !shared.config.faults.silent {
            for sub in &self.events {
                let recorded = &shared.config.identity.recorded;
                if let Some(e) = recorded.events(&sub.name).nth(sub.sent) {
                    at(sub.since + e.after);
                }
            }
        }
        if self.streaming() {
            let boot_end = shared.started + shared.config.startup_delay;
            at(self.next_scan.unwrap_or(now).max(boot_end));
        }
        due
    }

    /// Scans due by `now` (at most one per call; a late loop skips periods instead of
    /// bursting), with fault injection, and the recorded events due. Returns whether to drop
    /// the connection.
    pub(crate) fn tick(&mut self, now: Instant, out: &mut Vec<u8>) -> Verdict {
        let Some(d) = self.dialect else {
            return self.verdict;
        };
        if !self.shared.config.faults.silent {
            self.send_events(d, now, out);
        }
        if !self.subscribed
            || self.config_mode
            || self.booting(now)
            || self.shared.config.faults.silent
        {
            return self.verdict;
        }
        let period = self.period();
        let due = *self.next_scan.get_or_insert(now);
        if now < due {
            return self.verdict;
        }
        self.next_scan = Some(if now.duration_since(due) > period {
            now + period
        } else {
            due + period
        });
        let Some(scan) = self.make_scan(now, CommandType::Event) else {
            return self.verdict;
        };
        let faults = self.shared.config.faults;
        let k = self.scans_here + 1;
        if faults.garbage_every.is_some_and(|n| n > 0 && k % n == 0) {
            out.extend_from_slice(GARBAGE);
            self.shared.stats.count(|s| s.garbage_injections += 1);
        }
        let start = out.len();
        self.write_reply(d, Reply::Scan(scan), out);
        if faults.corrupt_every.is_some_and(|n| n > 0 && k % n == 0) && out.len() > start + 40 {
            corrupt(d, &mut out[start..]);
            self.shared.stats.count(|s| s.corrupted_scans += 1);
        }
        self.scans_here = k;
        self.shared.stats.count(|s| s.scans_sent += 1);
        if let Some(limit) = faults.drop_after_scans {
            if self.scans_here >= limit {
                let dropped = self.shared.stats.snapshot().drops;
                if faults.max_drops.is_none_or(|max| dropped < max) {
                    self.shared.stats.count(|s| s.drops += 1);
                    self.verdict = Verdict::Drop;
                }
            }
        }
        self.verdict
    }

    fn period(&self) -> Duration {
        let f = self.shared.settings().scan_config.frequency_1e2_hz.max(1);
        Duration::from_micros(100_000_000 / u64::from(f))
    }

    /// The next scan from the source, shaped by `LMDscandatacfg` and restamped.
    fn make_scan(&mut self, now: Instant, kind: CommandType) -> Option<ScanRepr> {
        let mut scan = self.shared.next_scan()?;
        scan.command_type = kind;
        let mut st = self.shared.settings();
        if st.echo_filter == EchoFilter::Last {
            last_echo_only(&mut scan);
        }
        let cfg = st.scan_data;
        let echo_on = |name: &[u8; 5]| {
            let n = name[4].wrapping_sub(b'0');
            (1..=5).contains(&n) && cfg.output_channel & (1 << (n - 1)) != 0
        };
        let keep = |c: &lidar_driver::ChannelRepr| match &c.name[..4] {
            b"DIST" => echo_on(&c.name),
            b"RSSI" => cfg.remission && echo_on(&c.name),
            _ => true,
        };
        scan.channels16.retain(keep);
        scan.channels8.retain(keep);
        let (sc, out) = (st.scan_config, st.output_range);
        reshape(
            &mut scan,
            &sc,
            out.start_1e4_deg.max(sc.start_1e4_deg),
            out.stop_1e4_deg.min(sc.stop_1e4_deg),
        );
        if !cfg.time {
            scan.time = None;
        }
        if self.shared.config.restamp {
            st.scans_sent += 1;
            let n = st.scans_sent;
            let h = &mut scan.header;
            h.scan_counter = n as u16;
            h.telegram_counter = n as u16;
            let t_us = now.duration_since(self.shared.started).as_micros() as u32;
            h.time_since_startup_us = t_us;
            h.time_of_transmission_us = t_us.wrapping_add(40_850);
            h.scan_frequency_1e2_hz = st.scan_config.frequency_1e2_hz;
            h.device_status = if n == 1 { [1, 0] } else { [0, 0] };
        }
        Some(scan)
    }
}

/// An answer to write.
enum Reply<'t> {
    Answer(Answer<'t>),
    Error(SopasError),
    EchoFilter(EchoFilter),
    Scan(ScanRepr),
    /// A recorded answer, replayed.
    Recorded(&'t RecordedTelegram),
    /// `sEA <event> <enabled>` for an event the answer of which was not recorded.
    EventAck(String, bool),
    None,
}

fn check_scan_config(
    c: &ScanConfig,
    field_of_view_1e4_deg: (i32, i32),
) -> Result<(), lidar_driver::answer::ScanConfigError> {
    use lidar_driver::answer::ScanConfigError as E;
    let freq_ok = LMS5XX_FREQUENCIES_1E2_HZ.contains(&c.frequency_1e2_hz);
    let step_ok = LMS5XX_STEPS_1E4_DEG.contains(&c.step_1e4_deg);
    let pair_ok = shots_100hz(c.frequency_1e2_hz, c.step_1e4_deg) <= LMS5XX_MAX_SHOTS_100HZ;
    let (lo, hi) = field_of_view_1e4_deg;
    let area_ok = c.sectors == 1
        && c.start_1e4_deg >= lo
        && c.stop_1e4_deg <= hi
        && c.start_1e4_deg < c.stop_1e4_deg;
    match (freq_ok, step_ok) {
        (false, false) => Err(E::FrequencyAndResolution),
        (false, true) => Err(E::Frequency),
        // A resolution too fine for the frequency: the resolution is what cannot be had.
        (true, false) => Err(E::Resolution),
        (true, true) if !pair_ok => Err(E::Resolution),
        (true, true) if !area_ok => Err(E::Area),
        (true, true) => Ok(()),
    }
}

/// `FREchoFilter` 2 (last echo): each beam's last echo in `DIST1` (and its remission in
/// `RSSI1`), the further echo channels dropped — one echo per beam, whatever
/// `LMDscandatacfg` enables. Echo `n` is channel `DISTn`; a beam's last echo is its last
/// non-zero value (0 is no further echo).
pub(crate) fn last_echo_only(scan: &mut ScanRepr) {
    let echo = |name: &[u8; 5], kind: &[u8]| {
        (&name[..4] == kind)
            .then(|| name[4].wrapping_sub(b'1'))
            .filter(|n| *n < 5)
    };
    let Some(first) = scan
        .channels16
        .iter()
        .position(|c| echo(&c.name, b"DIST") == Some(0))
    else {
        return;
    };
    let beams = scan.channels16[first].values.len();
    // Per beam, the index of the channel holding its last echo (DIST channels of other
    // lengths are left alone: not the same beams).
    let mut last = vec![first; beams];
    for (k, c) in scan.channels16.iter().enumerate() {
        if echo(&c.name, b"DIST").is_some_and(|n| n > 0) && c.values.len() == beams {
            for (l, v) in last.iter_mut().zip(&c.values) {
                if *v != 0 {
                    *l = k;
                }
            }
        }
    }
    let dist1: Vec<u16> = last
        .iter()
        .enumerate()
        .map(|(i, &k)| scan.channels16[k].values[i])
        .collect();
    // The remission channel of the same echo, 8- or 16-bit like the scanner's.
    let rssi = |channels: &[lidar_driver::ChannelRepr]| -> Option<Vec<u16>> {
        let of = |n: u8| {
            channels
                .iter()
                .find(|c| echo(&c.name, b"RSSI") == Some(n) && c.values.len() == beams)
        };
        of(0)?;
        Some(
            last.iter()
                .enumerate()
                .map(|(i, &k)| {
                    let n = echo(&scan.channels16[k].name, b"DIST").unwrap_or(0);
                    of(n).or_else(|| of(0)).map_or(0, |c| c.values[i])
                })
                .collect(),
        )
    };
    let (rssi16, rssi8) = (rssi(&scan.channels16), rssi(&scan.channels8));
    scan.channels16[first].values = dist1;
    for (channels, values) in [(&mut scan.channels16, rssi16), (&mut scan.channels8, rssi8)] {
        if let Some(v) = values {
            if let Some(c) = channels
                .iter_mut()
                .find(|c| echo(&c.name, b"RSSI") == Some(0))
            {
                c.values = v;
            }
        }
        channels.retain(|c| {
            !matches!(echo(&c.name, b"DIST"), Some(1..))
                && !matches!(echo(&c.name, b"RSSI"), Some(1..))
        });
    }
}

/// Lays `scan`'s channels out as the device is configured: `step` and the angles from
/// `start` to `stop` (1/10000°), each beam taking the source's nearest value (beams the
/// source did not cover read 0, no echo), with the header's frequencies to match. A scan
/// already laid out that way is left as it is.
pub(crate) fn reshape(scan: &mut ScanRepr, c: &ScanConfig, start_1e4_deg: i32, stop_1e4_deg: i32) {
    scan.header.scan_frequency_1e2_hz = c.frequency_1e2_hz;
    scan.header.measurement_frequency_100hz = shots_100hz(c.frequency_1e2_hz, c.step_1e4_deg);
    let step = c.step_1e4_deg.max(1);
    let span = i64::from(stop_1e4_deg) - i64::from(start_1e4_deg);
    // Rounded: the step is itself rounded to 1/10000° (1667 for 1/6°: 1140 steps span 190°).
    let beams = ((span.max(0) + i64::from(step) / 2) / i64::from(step)) as usize + 1;
    for ch in scan.channels16.iter_mut().chain(scan.channels8.iter_mut()) {
        if ch.start_angle_1e4_deg == start_1e4_deg
            && u32::from(ch.step_1e4_deg) == step
            && ch.values.len() == beams
        {
            continue;
        }
        let (a0, d0) = (
            i64::from(ch.start_angle_1e4_deg),
            i64::from(ch.step_1e4_deg.max(1)),
        );
        let values = (0..beams)
            .map(|i| {
                let a = i64::from(start_1e4_deg) + i as i64 * i64::from(step);
                let k = (a - a0 + d0 / 2).div_euclid(d0);
                usize::try_from(k)
                    .ok()
                    .and_then(|k| ch.values.get(k).copied())
                    .unwrap_or(0)
            })
            .collect();
        ch.values = values;
        ch.start_angle_1e4_deg = start_1e4_deg;
        ch.step_1e4_deg = u16::try_from(step).unwrap_or(u16::MAX);
    }
}

/// Noise between frames: stray start markers, a CoLa-B header claiming 4 GB, broken CoLa-A.
const GARBAGE: &[u8] = b"\x00\xff\x02\x02\x02\x02\xff\xff\xff\xff\x02noise\x01\x03xx\x02";

/// Damages a frame so the receiver must drop it: the CoLa-B checksum byte, or a control byte
/// in the middle of a CoLa-A frame.
fn corrupt(d: Dialect, frame: &mut [u8]) {
    match d {
        Dialect::ColaB => {
            if let Some(last) = frame.last_mut() {
                *last ^= 0x5a;
            }
        }
        Dialect::ColaA => {
            let mid = frame.len() / 2;
            if let Some(b) = frame.get_mut(mid) {
                *b = 0x01;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::LMS511_FOV_1E4_DEG;

    #[test]
    fn lms5xx_scan_modes_are_checked() {
        use lidar_driver::answer::ScanConfigError as E;
        let mut c = ScanConfig {
            frequency_1e2_hz: 5000,
            sectors: 1,
            step_1e4_deg: 3333,
            start_1e4_deg: -50_000,
            stop_1e4_deg: 1_850_000,
        };
        let check = |c: &ScanConfig| check_scan_config(c, LMS511_FOV_1E4_DEG);
        assert_eq!(check(&c), Ok(()));
        // Every resolution of the manual at 25 Hz, none finer than 0.3333° at 50 Hz.
        for step in LMS5XX_STEPS_1E4_DEG {
            let at = |f| ScanConfig {
                frequency_1e2_hz: f,
                step_1e4_deg: step,
                ..c
            };
            assert_eq!(check(&at(2500)), Ok(()), "25 Hz at {step}");
            assert_eq!(check(&at(5000)).is_ok(), step >= 3333, "50 Hz at {step}");
            assert_eq!(check(&at(10000)).is_ok(), step >= 6667, "100 Hz at {step}");
            assert_eq!(check(&at(3500)).is_ok(), step >= 2500, "35 Hz at {step}");
        }
        c.step_1e4_deg = 1667;
        assert_eq!(check(&c), Err(E::Resolution));
        c.frequency_1e2_hz = 6000;
        assert_eq!(check(&c), Err(E::Frequency));
        c.step_1e4_deg = 1234;
        assert_eq!(check(&c), Err(E::FrequencyAndResolution));
        c.frequency_1e2_hz = 2500;
        c.step_1e4_deg = 1667;
        c.stop_1e4_deg = 2_000_000;
        assert_eq!(check(&c), Err(E::Area));
        assert_eq!(shots_100hz(2500, 1667), 540);
        assert_eq!(shots_100hz(3500, 2500), 504);
    }

    #[test]
    fn scans_are_laid_out_as_configured() {
        let mut scan = ScanRepr::parse(
            &lidar_driver::ScanData::new_checked(
                lidar_driver::Frame::new_checked(&first_capture_scan()).unwrap(),
            )
            .unwrap(),
        );
        let original = scan.channels16[0].values.clone();
        let c = ScanConfig {
            frequency_1e2_hz: 5000,
            sectors: 1,
            step_1e4_deg: 3333,
            start_1e4_deg: -50_000,
            stop_1e4_deg: 1_850_000,
        };
        reshape(&mut scan, &c, c.start_1e4_deg, c.stop_1e4_deg);
        let d = &scan.channels16[0];
        assert_eq!((d.values.len(), d.step_1e4_deg), (571, 3333));
        // Every second beam of the 1/6° scan.
        for (i, v) in d.values.iter().enumerate() {
            assert_eq!(*v, original[2 * i], "beam {i}");
        }
        assert_eq!(scan.channels8[0].values.len(), 571);
        assert_eq!(
            (
                scan.header.scan_frequency_1e2_hz,
                scan.header.measurement_frequency_100hz
            ),
            (5000, 540)
        );
        // An output range of 0°…180° at 0.5°: 361 beams from 0°.
        let c = ScanConfig {
            frequency_1e2_hz: 2500,
            step_1e4_deg: 5000,
            ..c
        };
        reshape(&mut scan, &c, 0, 1_800_000);
        assert_eq!(scan.channels16[0].values.len(), 361);
        assert_eq!(scan.channels16[0].start_angle_1e4_deg, 0);
    }

    /// The first scan of the LMS511 capture, as a frame.
    fn first_capture_scan() -> Vec<u8> {
        let rec = lidar_driver::recording::Recording::read_file(sick_captures::path(
            sick_captures::LMS511_S2H,
        ))
        .unwrap();
        rec.frames()
            .frames
            .into_iter()
            .find(|f| lidar_driver::ScanData::new_checked(f.frame()).is_ok())
            .unwrap()
            .bytes
    }

    mod props {
        use super::*;
        use crate::{EmulatorConfig, Shared};
        use lidar_driver::framer::Framer;
        use proptest::prelude::*;

        fn shared() -> Shared {
            let cfg = EmulatorConfig::default();
            Shared::new(cfg, Box::new(|| None))
        }

        proptest! {
            #![proptest_config(ProptestConfig::with_cases(256))]

            /// Arbitrary bytes (and request-like telegrams) never panic the emulator, and
            /// everything it sends back is a well-formed frame in the connection's dialect.
            #[test]
            fn any_input_gets_well_formed_answers(
                junk in proptest::collection::vec(any::<u8>(), 0..300),
                words in proptest::collection::vec(
                    prop_oneof![
                        Just("sRN".to_string()), Just("sWN".to_string()), Just("sMN".to_string()),
                        Just("sEN".to_string()), Just("SetAccessMode".to_string()),
                        Just("LMPoutputRange".to_string()), Just("mLMPsetscancfg".to_string()),
                        Just("FF".to_string()), Just("3".to_string()), "[A-Za-z0-9+-]{1,9}",
                    ],
                    0..8),
                binary in any::<bool>(),
            ) {
                let sh = shared();
                let mut conn = Connection::new(&sh);
                let mut input = junk;
                let text = words.join(" ");
                if binary {
                    let mut f = vec![2, 2, 2, 2];
                    f.extend_from_slice(&(text.len() as u32).to_be_bytes());
                    f.extend_from_slice(text.as_bytes());
                    f.push(lidar_driver::frame::xor_checksum(text.as_bytes()));
                    input.extend_from_slice(&f);
                } else {
                    input.push(2);
                    input.extend_from_slice(text.as_bytes());
                    input.push(3);
                }
                let mut out = Vec::new();
                let mut framer = Framer::new(vec![0u8; 4096]);
                let now = Instant::now();
                framer.feed(&input, |r| {
                    if let Ok(f) = r {
                        conn.on_frame(f, now, &mut out);
                    }
                });
                let _ = conn.tick(now, &mut out);
                let mut back = Framer::new(vec![0u8; 64 * 1024]);
                let mut n = 0;
                let mut bad = 0;
                back.feed(&out, |r| match r {
                    Ok(f) => {
                        n += 1;
                        if Answer::from_frame(f).is_err() {
                            bad += 1;
                        }
                    }
                    Err(_) => bad += 1,
                });
                prop_assert_eq!(bad, 0);
                prop_assert_eq!(back.stats().garbage_bytes, 0);
                prop_assert!(n <= sh.stats.snapshot().frames_in as usize);
            }
        }
    }
}
