//! State-machine tests with a scripted in-memory transport and a hand-driven clock: every
//! time-out is exercised without sleeping.

use core::cell::Cell;
use std::collections::VecDeque;

use super::*;
use crate::answer::Answer;
use crate::request::{OutputRange, Request, ScanConfig};
use crate::sopas_error::SopasError;

/// Bytes the "sensor" sent wait in `rx`; what the session sent lands in `tx`.
#[derive(Default)]
struct Mock {
    rx: VecDeque<u8>,
    tx: Vec<u8>,
    open: bool,
    opens: u32,
    refuse: bool,
    eof: bool,
}

impl embedded_io::ErrorType for Mock {
    type Error = embedded_io::ErrorKind;
}
impl embedded_io::Read for Mock {
    fn read(&mut self, buf: &mut [u8]) -> Result<usize, Self::Error> {
        if !self.open {
            return Err(embedded_io::ErrorKind::NotConnected);
        }
        if self.rx.is_empty() && self.eof {
            return Ok(0);
        }
        let n = buf.len().min(self.rx.len());
        for (d, s) in buf.iter_mut().zip(self.rx.drain(..n)) {
            *d = s;
        }
        if n == 0 {
            return Err(embedded_io::ErrorKind::TimedOut);
        }
        Ok(n)
    }
}
impl embedded_io::ReadReady for Mock {
    fn read_ready(&mut self) -> Result<bool, Self::Error> {
        Ok(!self.rx.is_empty() || self.eof)
    }
}
impl embedded_io::Write for Mock {
    fn write(&mut self, buf: &[u8]) -> Result<usize, Self::Error> {
        if !self.open {
            return Err(embedded_io::ErrorKind::NotConnected);
        }
        self.tx.extend_from_slice(buf);
        Ok(buf.len())
    }
    fn flush(&mut self) -> Result<(), Self::Error> {
        Ok(())
    }
}
impl Transport for Mock {
    fn reconnect(&mut self) -> Result<(), Self::Error> {
        self.opens += 1;
        self.eof = false;
        self.rx.clear();
        if self.refuse {
            return Err(embedded_io::ErrorKind::ConnectionRefused);
        }
        self.open = true;
        Ok(())
    }
    fn close(&mut self) {
        self.open = false;
    }
}

impl Mock {
    /// Requests sent since the last call, as (dialect, owned request telegram bytes).
    fn take_requests(&mut self) -> Vec<(Dialect, Vec<u8>)> {
        let mut f = Framer::new(vec![0u8; 1024]);
        let mut out = Vec::new();
        f.feed(&self.tx, |r| {
            let fr = r.unwrap();
            out.push((fr.dialect(), fr.as_bytes().to_vec()));
        });
        self.tx.clear();
        out
    }

    fn send(&mut self, d: Dialect, a: Answer<'_>) {
        let mut b = [0u8; 256];
        let n = a.emit(d, &mut b).unwrap();
        self.rx.extend(&b[..n]);
    }
}

/// The answer a healthy, ready LMS511 gives.
fn ok_answer(r: &Request<'_>) -> Answer<'static> {
    match *r {
        Request::SetAccessMode { .. } => Answer::AccessMode { accepted: true },
        Request::Read(names::DEVICE_STATE) => Answer::DeviceState(DeviceState::Ready),
        Request::Read(names::FIRMWARE_VERSION) => Answer::FirmwareVersion(b"V1.80    "),
        Request::Read(names::LOCATION_NAME) => Answer::LocationName(b"SN 18110550"),
        Request::Read(names::OUTPUT_RANGE) => Answer::OutputRange(RANGE),
        Request::Read(names::SCAN_DATA_CONFIG) => {
            Answer::ScanDataConfig(SessionConfig::CAPTURE_SCAN_DATA)
        }
        Request::Read(names::SCAN_CONFIG) => Answer::ScanConfig(SCAN_50HZ),
        Request::SetScanConfig(c) => Answer::SetScanConfig {
            result: Ok(()),
            in_effect: Some(c),
        },
        Request::StartMeasurement => Answer::StartMeasurement { ok: true },
        Request::Run => Answer::Run { ok: true },
        Request::Subscribe { .. } => Answer::EventAck {
            event: names::SCAN_DATA,
            enabled: true,
        },
        Request::SetOutputRange(_) => Answer::WriteAck(names::OUTPUT_RANGE),
        Request::SetScanDataConfig(_) => Answer::WriteAck(names::SCAN_DATA_CONFIG),
        Request::SetEchoFilter(_) => Answer::WriteAck(names::ECHO_FILTER),
        _ => Answer::Error(SopasError::UnknownVariable),
    }
}

const RANGE: OutputRange = OutputRange {
    sectors: 1,
    step_1e4_deg: 1667,
    start_1e4_deg: -50_000,
    stop_1e4_deg: 1_850_000,
};

const SCAN_50HZ: ScanConfig = ScanConfig {
    frequency_1e2_hz: 5000,
    sectors: 1,
    step_1e4_deg: 3333,
    start_1e4_deg: -50_000,
    stop_1e4_deg: 1_850_000,
};

fn cfg() -> SessionConfig {
    SessionConfig {
        timeouts: Timeouts {
            probe_ms: 100,
            answer_ms: 200,
            ready_poll_ms: 50,
            ready_ms: 1000,
            scan_ms: 300,
            first_scan_ms: 600,
            reconnect_delay_ms: 500,
        },
        ..SessionConfig::default()
    }
}

/// Polls until `Idle`, answering every request with `answer`; returns the events as text.
fn pump(
    s: &mut Session<Vec<u8>>,
    io: &mut Mock,
    clock: &Cell<u64>,
    mut answer: impl FnMut(&Request<'_>) -> Option<Answer<'static>>,
) -> Vec<String> {
    let mut log = Vec::new();
    for _ in 0..1000 {
        let c = || clock.get();
        let ev = s.poll(io, &c);
        if ev == Event::Idle {
            if io.tx.is_empty() {
                break;
            }
        } else {
            log.push(format!("{ev:?}"));
        }
        for (d, bytes) in io.take_requests() {
            let f = Frame::new_checked(&bytes).unwrap();
            let r = Request::from_frame(f).unwrap();
            if let Some(a) = answer(&r) {
                io.send(d, a);
            }
        }
    }
    log
}

/// A hand-driven clock at 0, a scripted transport and a session with `config`.
fn fresh(config: SessionConfig) -> (Cell<u64>, Mock, Session<Vec<u8>>) {
    (
        Cell::new(0),
        Mock::default(),
        Session::new(vec![0u8; 4096], config),
    )
}

#[test]
fn full_start_up_then_streaming() {
    let (clock, mut io, mut s) = fresh(SessionConfig {
        scan_config: Some(SCAN_50HZ),
        output_range: Some(RANGE),
        ..cfg()
    });
    let log = pump(&mut s, &mut io, &clock, |r| Some(ok_answer(r)));
    assert_eq!(s.phase(), Phase::Streaming, "{log:#?}");
    assert_eq!(
        log.first().map(String::as_str),
        Some("Connected { attempt: 1 }")
    );
    assert!(log.contains(&"DialectDetected(ColaB)".to_string()));
    assert!(
        log.contains(&"StepDone(SetScanConfig)".to_string()),
        "{log:#?}"
    );
    assert_eq!(log.last().map(String::as_str), Some("Streaming"));
    assert_eq!(s.stats().streams_started, 1);
}

#[test]
fn silence_times_out_per_dialect_then_reconnects_after_the_delay() {
    let clock = Cell::new(0);
    let mut io = Mock::default();
    let mut s = Session::new(vec![0u8; 4096], cfg());
    let c = || clock.get();
    assert_eq!(s.poll(&mut io, &c), Event::Connected { attempt: 1 });
    assert_eq!(s.poll(&mut io, &c), Event::Probing(Dialect::ColaB));
    assert_eq!(s.poll(&mut io, &c), Event::Idle);
    clock.set(99);
    assert_eq!(s.poll(&mut io, &c), Event::Idle);
    clock.set(100);
    assert_eq!(s.poll(&mut io, &c), Event::Probing(Dialect::ColaA));
    assert_eq!(io.opens, 2, "re-opened before the other dialect");
    let sent = io.take_requests();
    assert_eq!(sent.len(), 2);
    assert_eq!(sent[1].1, b"\x02sRN SCdevicestate\x03");
    clock.set(200);
    let ev = s.poll(&mut io, &c);
    assert_eq!(
        ev,
        Event::Reconnecting {
            error: SessionError::NoAnswer { waited_ms: 100 },
            failed_attempts: 1,
            retry_in_ms: 500
        }
    );
    assert!(!io.open, "closed while waiting");
    clock.set(699);
    assert_eq!(s.poll(&mut io, &c), Event::Idle);
    clock.set(700);
    assert_eq!(s.poll(&mut io, &c), Event::Connected { attempt: 2 });
    assert_eq!(s.stats().timeouts, 2);
}

/// A device that always answers `SCdevicestate 0` (in configuration mode, as SICK's Python
/// test server does) is logged in and put into measurement, as SICK's driver does: no
/// polling until the ready time-out.
#[test]
fn a_device_that_always_says_busy_is_started_anyway() {
    let (clock, mut io, mut s) = fresh(cfg());
    let log = pump(&mut s, &mut io, &clock, |r| match r {
        Request::Read(names::DEVICE_STATE) => Some(Answer::DeviceState(DeviceState::Busy)),
        r => Some(ok_answer(r)),
    });
    assert_eq!(s.phase(), Phase::Streaming, "{log:#?}");
    assert_eq!(clock.get(), 0, "no waiting");
    assert!(log.contains(&"DeviceNotReady { state: Busy, waited_ms: 0 }".to_string()));
    assert!(log.iter().any(|l| l == "StepDone(Run)"), "{log:#?}");
}

/// A booting device answers `SCdevicestate 0` and refuses the login with `sFA 13` (server
/// busy): the session polls it and starts up once it accepts.
#[test]
fn a_booting_device_is_polled_until_it_accepts_the_login() {
    let (clock, mut io, mut s) = fresh(cfg());
    let mut refusals_left = 3;
    let mut log = Vec::new();
    for t in (0..400).step_by(10) {
        clock.set(t);
        log.extend(pump(&mut s, &mut io, &clock, |r| match r {
            Request::Read(names::DEVICE_STATE) => Some(Answer::DeviceState(DeviceState::Busy)),
            Request::SetAccessMode { .. } if refusals_left > 0 => {
                refusals_left -= 1;
                Some(Answer::Error(SopasError::ServerBusy))
            }
            r => Some(ok_answer(r)),
        }));
    }
    let busy: Vec<_> = log
        .iter()
        .filter(|l| l.starts_with("DeviceNotReady"))
        .collect();
    // One per SCdevicestate answer and one per refusal, counted from the first.
    assert!(busy.len() >= 6, "{log:#?}");
    assert_eq!(busy[0], "DeviceNotReady { state: Busy, waited_ms: 0 }");
    assert!(busy.last().unwrap().contains("waited_ms: 150"), "{log:#?}");
    assert_eq!(s.phase(), Phase::Streaming, "{log:#?}");
    assert_eq!(refusals_left, 0);
}

/// A device that stays in error (`SCdevicestate 2`) is polled and reported as in error.
#[test]
fn a_device_in_error_is_reported_as_such() {
    let (clock, mut io, mut s) = fresh(cfg());
    let mut log = Vec::new();
    for t in (0..=1100).step_by(10) {
        clock.set(t);
        log.extend(pump(&mut s, &mut io, &clock, |r| match r {
            Request::Read(names::DEVICE_STATE) => Some(Answer::DeviceState(DeviceState::Error)),
            r => Some(ok_answer(r)),
        }));
    }
    assert!(
        log.iter()
            .any(|l| l.contains("DeviceNotReady { state: Error, waited_ms: 1000 }")),
        "{log:#?}"
    );
    let e = SessionError::DeviceNotReady {
        state: DeviceState::Error,
        waited_ms: 1000,
    };
    assert!(e.to_string().contains("error state"), "{e}");
}

#[test]
fn method_accepted_restarts_the_answer_timeout() {
    let (clock, mut io, mut s) = fresh(SessionConfig {
        scan_config: Some(SCAN_50HZ),
        ..cfg()
    });
    // Everything answered at once except mLMPsetscancfg, which only gets sMA.
    pump(&mut s, &mut io, &clock, |r| match r {
        Request::SetScanConfig(_) => Some(Answer::MethodAccepted(names::SET_SCAN_CONFIG)),
        r => Some(ok_answer(r)),
    });
    assert_eq!(s.phase(), Phase::StartingUp(Step::SetScanConfig));
    clock.set(150);
    io.send(
        Dialect::ColaB,
        Answer::MethodAccepted(names::SET_SCAN_CONFIG),
    );
    pump(&mut s, &mut io, &clock, |r| Some(ok_answer(r)));
    clock.set(300); // 300 ms after the request, 150 ms after the second sMA: still waiting
    pump(&mut s, &mut io, &clock, |r| Some(ok_answer(r)));
    assert_eq!(s.phase(), Phase::StartingUp(Step::SetScanConfig));
    io.send(
        Dialect::ColaB,
        Answer::SetScanConfig {
            result: Ok(()),
            in_effect: None,
        },
    );
    pump(&mut s, &mut io, &clock, |r| Some(ok_answer(r)));
    assert_eq!(s.phase(), Phase::Streaming);
}

#[test]
fn late_answers_and_noise_are_skipped_not_fatal() {
    let clock = Cell::new(0);
    let mut io = Mock::default();
    let mut s = Session::new(vec![0u8; 4096], cfg());
    let mut first = true;
    let log = pump(&mut s, &mut io, &clock, |r| {
        if first && matches!(r, Request::SetAccessMode { .. }) {
            first = false;
            // A stale answer from an earlier request arrives first; then the real one.
            return Some(Answer::OperatingHours(1195));
        }
        Some(ok_answer(r))
    });
    // The login got no answer of its own: it times out and the attempt is retried cleanly.
    assert_eq!(s.phase(), Phase::StartingUp(Step::Login), "{log:#?}");
    assert!(log
        .iter()
        .any(|l| l.contains("Ignored { kind: Some(ReadAnswer), name: \"ODoprh\" }")));
    clock.set(250);
    let log = pump(&mut s, &mut io, &clock, |r| Some(ok_answer(r)));
    assert!(log[0].contains("Timeout { step: Login"), "{log:#?}");
    clock.set(800);
    io.rx
        .extend(b"\x02\x02\x02\x02\xff\xff\xff\xffnoise\x02sXX junk\x03");
    let log = pump(&mut s, &mut io, &clock, |r| Some(ok_answer(r)));
    assert_eq!(s.phase(), Phase::Streaming, "{log:#?}");
    assert!(s.stats().ignored_frames >= 1);
}

#[test]
fn sfa_in_the_other_dialect_during_the_probe_reveals_the_dialect() {
    let clock = Cell::new(0);
    let mut io = Mock::default();
    let mut s = Session::new(vec![0u8; 4096], cfg());
    let c = || clock.get();
    s.poll(&mut io, &c);
    s.poll(&mut io, &c);
    io.take_requests();
    io.send(
        Dialect::ColaA,
        Answer::Error(SopasError::UnknownColaCommand),
    );
    assert_eq!(s.poll(&mut io, &c), Event::DialectDetected(Dialect::ColaA));
    let sent = io.take_requests();
    assert_eq!(sent[0].1, b"\x02sRN SCdevicestate\x03");
    assert_eq!(s.dialect(), Some(Dialect::ColaA));
}

#[test]
fn refused_step_is_a_typed_error_and_gives_up_when_configured() {
    let (clock, mut io, mut s) = fresh(SessionConfig {
        max_failed_attempts: Some(1),
        ..cfg()
    });
    let log = pump(&mut s, &mut io, &clock, |r| match r {
        Request::Run => Some(Answer::Error(SopasError::AccessDenied)),
        r => Some(ok_answer(r)),
    });
    let last = log.last().unwrap();
    assert_eq!(
        last,
        &format!(
            "{:?}",
            Event::Failed(SessionError::Refused {
                step: Step::Run,
                error: SopasError::AccessDenied
            })
        )
    );
    let msg = SessionError::Refused {
        step: Step::Run,
        error: SopasError::AccessDenied,
    }
    .to_string();
    assert!(msg.starts_with("leaving configuration mode (sMN Run) refused: sensor error 1 (access denied): log in first"), "{msg}");
}

#[test]
fn connection_refused_and_end_of_stream_reconnect() {
    let clock = Cell::new(0);
    let mut io = Mock {
        refuse: true,
        ..Mock::default()
    };
    let mut s = Session::new(vec![0u8; 4096], cfg());
    let c = || clock.get();
    match s.poll(&mut io, &c) {
        Event::Reconnecting { error, .. } => assert_eq!(
            error,
            SessionError::Transport {
                op: IoOp::Connect,
                kind: embedded_io::ErrorKind::ConnectionRefused
            }
        ),
        e => panic!("{e:?}"),
    }
    io.refuse = false;
    clock.set(500);
    pump(&mut s, &mut io, &clock, |r| Some(ok_answer(r)));
    assert_eq!(s.phase(), Phase::Streaming);
    io.eof = true;
    let ev = s.poll(&mut io, &c);
    assert!(
        matches!(
            ev,
            Event::Reconnecting {
                error: SessionError::ConnectionClosed,
                ..
            }
        ),
        "{ev:?}"
    );
}

#[test]
fn the_first_scan_gets_its_own_longer_timeout() {
    let clock = Cell::new(0);
    let mut io = Mock::default();
    let mut s = Session::new(vec![0u8; 4096], cfg());
    pump(&mut s, &mut io, &clock, |r| Some(ok_answer(r)));
    assert_eq!(s.phase(), Phase::Streaming);
    let c = || clock.get();
    // Past the 300 ms between scans but within the 600 ms for the first one.
    clock.set(599);
    assert_eq!(s.poll(&mut io, &c), Event::Idle);
    clock.set(600);
    let ev = s.poll(&mut io, &c);
    assert!(
        matches!(
            ev,
            Event::Reconnecting {
                error: SessionError::ScanTimeout {
                    waited_ms: 600,
                    first: true
                },
                ..
            }
        ),
        "{ev:?}"
    );
    assert!(ev.to_string().contains("first scan"), "{ev}");
    assert_eq!(s.phase(), Phase::Disconnected);
}

#[test]
fn no_scan_within_the_scan_timeout_after_the_first_reconnects() {
    let clock = Cell::new(0);
    let mut io = Mock::default();
    let mut s = Session::new(vec![0u8; 4096], cfg());
    pump(&mut s, &mut io, &clock, |r| Some(ok_answer(r)));
    let c = || clock.get();
    clock.set(100);
    io.rx.extend(stream_props::recorded_scans(1).remove(0));
    assert!(matches!(s.poll(&mut io, &c), Event::Scan(_)));
    clock.set(399);
    assert_eq!(s.poll(&mut io, &c), Event::Idle);
    clock.set(400);
    assert!(matches!(
        s.poll(&mut io, &c),
        Event::Reconnecting {
            error: SessionError::ScanTimeout {
                waited_ms: 300,
                first: false
            },
            ..
        }
    ));
}

mod stream_props {
    use super::*;
    use proptest::prelude::*;

    /// The first `n` scans of the LMS511 capture's sensor stream, as CoLa-B frames.
    pub(super) fn recorded_scans(n: usize) -> Vec<Vec<u8>> {
        let bytes = sick_captures::read(sick_captures::LMS511_S2H);
        let mut f = Framer::new(vec![0u8; 64 * 1024]);
        let mut out = Vec::new();
        f.feed(&bytes, |r| {
            let fr = r.expect("clean capture");
            if fr.payload().starts_with(b"sSN LMDscandata ") {
                out.push(fr.as_bytes().to_vec());
            }
        });
        out.truncate(n);
        out
    }

    fn streaming_session(io: &mut Mock, clock: &Cell<u64>) -> Session<Vec<u8>> {
        let mut s = Session::new(vec![0u8; 16 * 1024], cfg());
        pump(&mut s, io, clock, |r| Some(ok_answer(r)));
        assert_eq!(s.phase(), Phase::Streaming);
        s
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(48))]

        /// Scans interleaved with garbage, late answers and damaged scans, cut into arbitrary
        /// chunks: every intact scan arrives, in order, and the stream never stalls or
        /// re-connects.
        #[test]
        fn intact_scans_always_arrive(
            seed_chunks in proptest::collection::vec(1usize..6000, 1..40),
            noise in proptest::collection::vec(
                (0usize..4, proptest::collection::vec(
                    prop_oneof![Just(2u8), Just(3u8), any::<u8>(), 0x20u8..0x7f], 0..40)),
                12),
        ) {
            let scans = recorded_scans(12);
            let clock = Cell::new(0);
            let mut io = Mock::default();
            let mut s = streaming_session(&mut io, &clock);
            let mut stream = Vec::new();
            let mut expected = Vec::new();
            for (i, (scan, (what, junk))) in scans.iter().zip(&noise).enumerate() {
                match what {
                    0 => stream.extend_from_slice(junk),
                    1 => {
                        let mut b = [0u8; 64];
                        let n = Answer::OperatingHours(i as u32).emit(Dialect::ColaB, &mut b).unwrap();
                        stream.extend_from_slice(&b[..n]);
                    }
                    2 => {
                        // A damaged copy of the scan first: dropped alone.
                        let mut bad = scan.clone();
                        let k = 30 + junk.len() * 7 % (bad.len() - 31);
                        bad[k] ^= 0x40;
                        stream.extend_from_slice(&bad);
                    }
                    _ => {}
                }
                stream.extend_from_slice(scan);
                expected.push(u16::from_be_bytes([scan[36], scan[37]]));
            }
            let mut got = Vec::new();
            let mut rest = &stream[..];
            let mut sizes = seed_chunks.iter().cycle();
            let c = || clock.get();
            for _ in 0..100_000 {
                if rest.is_empty() && io.rx.is_empty() {
                    // Drain what the framer still holds.
                    let mut idle = 0;
                    while idle < 3 {
                        match s.poll(&mut io, &c) {
                            Event::Idle => idle += 1,
                            Event::Scan(sc) => got.push(sc.header.scan_counter),
                            Event::Reconnecting { error, .. } => prop_assert!(false, "{error}"),
                            _ => {}
                        }
                    }
                    break;
                }
                if io.rx.is_empty() {
                    let n = (*sizes.next().unwrap()).min(rest.len());
                    io.rx.extend(&rest[..n]);
                    rest = &rest[n..];
                }
                match s.poll(&mut io, &c) {
                    Event::Scan(sc) => got.push(sc.header.scan_counter),
                    Event::Reconnecting { error, .. } => prop_assert!(false, "{error}"),
                    _ => {}
                }
            }
            prop_assert_eq!(got, expected);
            prop_assert_eq!(s.stats().failures, 0);
        }
    }
}

#[test]
fn session_memory_is_the_buffer_plus_a_few_hundred_bytes() {
    // The firmware budgets RAM: the session adds its state and a 128-byte transmit buffer to
    // the caller's receive buffer, nothing else (no heap).
    let extra = core::mem::size_of::<Session<[u8; 16 * 1024]>>() - 16 * 1024;
    println!("Session<[u8; 16384]> = buffer + {extra} bytes");
    assert!(extra < 1024, "{extra}");
}

#[test]
fn events_read_as_log_lines() {
    let busy = Event::DeviceNotReady {
        state: DeviceState::Busy,
        waited_ms: 1200,
    };
    assert_eq!(
        busy.to_string(),
        "device busy (SCdevicestate 0: starting up or in configuration mode) for 1200 ms; logging in and starting the measurement"
    );
    assert_eq!(
        Event::Info(DeviceInfo::FirmwareVersion(b"V1.80    ")).to_string(),
        "firmware V1.80    "
    );
    assert_eq!(
        Event::Info(DeviceInfo::OutputRange(RANGE)).to_string(),
        "output range -5..185 deg, step 0.1667 deg"
    );
    let r = Event::Reconnecting {
        error: SessionError::ScanTimeout {
            waited_ms: 1000,
            first: false,
        },
        failed_attempts: 1,
        retry_in_ms: 1000,
    };
    assert!(r
        .to_string()
        .starts_with("no scan for 1000 ms while streaming"));
}

#[test]
fn stop_unsubscribes_closes_and_stays_quiet() {
    let clock = Cell::new(0);
    let mut io = Mock::default();
    let mut s = Session::new(vec![0u8; 4096], cfg());
    pump(&mut s, &mut io, &clock, |r| Some(ok_answer(r)));
    assert_eq!(s.phase(), Phase::Streaming);
    s.stop(&mut io);
    let sent = io.take_requests();
    assert_eq!(sent.len(), 1);
    assert_eq!(
        Request::from_frame(Frame::new_checked(&sent[0].1).unwrap()).unwrap(),
        Request::Subscribe {
            event: names::SCAN_DATA,
            enable: false
        }
    );
    assert!(!io.open);
    clock.set(1_000_000);
    let c = || clock.get();
    assert_eq!(s.poll(&mut io, &c), Event::Idle);
    assert_eq!(s.phase(), Phase::Stopped);
    assert_eq!(io.opens, 1, "no re-connect after stop");
    s.restart();
    assert_eq!(s.poll(&mut io, &c), Event::Connected { attempt: 1 });
}
