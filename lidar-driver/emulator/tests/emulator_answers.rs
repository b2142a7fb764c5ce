//! The emulator answers the LMS511 start-up dialogue of the capture byte for byte (CoLa-B) —
//! every request of it, the field definitions, input states and event subscriptions
//! included, and the start-up sequence SICK's own driver (sick_scan_xd 3.9.0) sends —, the
//! same typed answers in CoLa-A, `sFA` for what it does not know or what needs a login.

mod session_support;

use std::io::{Read, Write};
use std::net::TcpStream;
use std::time::{Duration, Instant};

use lidar_driver::{Answer, CommandType, Dialect, Framer, Request, SopasError, Telegram};
use lms5xx_emulator::{Emulator, EmulatorConfig};

use session_support::*;

/// All frames of a raw capture stream.
fn frames(name: &str) -> Vec<Vec<u8>> {
    let bytes = std::fs::read(capture(name)).unwrap();
    let mut f = Framer::new(vec![0u8; 64 * 1024]);
    let mut out = Vec::new();
    f.feed(&bytes, |r| out.push(r.unwrap().as_bytes().to_vec()));
    out
}

fn kind_of(frame: &[u8]) -> (CommandType, String) {
    let f = lidar_driver::Frame::new_checked(frame).unwrap();
    let t = Telegram::parse(f).unwrap();
    (t.kind(), t.name().to_string())
}

/// A raw client: sends a frame, returns the next frame that is not a streamed event.
struct Client {
    s: TcpStream,
    framer: Framer<Vec<u8>>,
    ready: Vec<Vec<u8>>,
}

impl Client {
    fn connect(emu: &Emulator) -> Self {
        let s = TcpStream::connect(emu.addr().unwrap()).unwrap();
        s.set_read_timeout(Some(Duration::from_millis(20))).unwrap();
        Client {
            s,
            framer: Framer::new(vec![0u8; 64 * 1024]),
            ready: Vec::new(),
        }
    }

    fn ask(&mut self, req: &[u8]) -> Vec<u8> {
        self.s.write_all(req).unwrap();
        let end = Instant::now() + Duration::from_secs(2);
        let mut buf = [0u8; 8192];
        loop {
            while !self.ready.is_empty() {
                let f = self.ready.remove(0);
                if kind_of(&f).0 != CommandType::Event {
                    return f;
                }
            }
            assert!(Instant::now() < end, "no answer to {:?}", kind_of(req));
            match self.s.read(&mut buf) {
                Ok(0) => panic!("emulator closed the connection"),
                Ok(n) => {
                    let ready = &mut self.ready;
                    self.framer
                        .feed(&buf[..n], |r| ready.push(r.unwrap().as_bytes().to_vec()));
                }
                Err(_) => {}
            }
        }
    }
}

/// The capture's requests paired with the sensor's answers (streamed events left out).
fn capture_dialogue() -> Vec<(Vec<u8>, Vec<u8>)> {
    let reqs = frames("lms511_20210302_colab.host_to_sensor.colab.bin");
    let answers: Vec<Vec<u8>> = frames("lms511_20210302_colab.sensor_to_host.colab.bin")
        .into_iter()
        .filter(|f| kind_of(f).0 != CommandType::Event)
        .collect();
    assert_eq!(reqs.len(), answers.len());
    reqs.into_iter().zip(answers).collect()
}

/// Names whose answers the emulator builds from typed values (the rest it replays as the
/// capture recorded them: field000…029, the I/O states, LFErec).
fn typed(name: &str) -> bool {
    !(name.starts_with("field") || name.starts_with("LID") || name == "LFErec")
}

#[test]
fn cola_b_answers_equal_the_lms511_capture() {
    let emu = Emulator::start(EmulatorConfig::default(), lms511_source()).unwrap();
    let mut c = Client::connect(&emu);
    let mut compared = 0;
    for (req, want) in capture_dialogue() {
        let (kind, name) = kind_of(&req);
        let got = c.ask(&req);
        assert_eq!(got, want, "{kind} {name}");
        compared += 1;
    }
    // Every request of the capture: SetAccessMode, EIHstCola, FirmwareVersion,
    // SCdevicestate, ODoprh, ODpwrc, LocationName, LMPoutputRange ×3, field000…029,
    // LIDinputstate, LMDscandatacfg ×2, LMCstartmeas, Run, sEN LMDscandata, LFErec,
    // LIDoutputstate, LIDinputstate.
    assert_eq!(compared, 49);
    let st = emu.stop();
    assert_eq!((st.requests, st.connections), (49, 1), "{st:?}");
}

/// The capture's sensor frames of subscription `name` (`sSN`), in order.
fn capture_events(name: &str) -> Vec<Vec<u8>> {
    frames("lms511_20210302_colab.sensor_to_host.colab.bin")
        .into_iter()
        .filter(|f| kind_of(f) == (CommandType::Event, name.to_string()))
        .collect()
}

/// After `sEN LIDoutputstate 1` / `sEN LFErec 1` the recorded events arrive, byte for byte as
/// the LMS511 sent them, at their recorded times (the fourth LIDoutputstate and the LFErec
/// 1.1 s after the subscription).
#[test]
fn subscribed_events_arrive_as_the_lms511_sent_them() {
    let emu = Emulator::start(EmulatorConfig::default(), lms511_source()).unwrap();
    let mut c = Client::connect(&emu);
    let mut events = Vec::new();
    for name in ["LIDoutputstate", "LFErec"] {
        let mut req = [0u8; 64];
        let n = Request::Subscribe {
            event: name,
            enable: true,
        }
        .emit(Dialect::ColaB, &mut req)
        .unwrap();
        let ack = c.ask(&req[..n]);
        assert_eq!(kind_of(&ack), (CommandType::EventAnswer, name.to_string()));
    }
    let end = Instant::now() + Duration::from_secs(3);
    let mut buf = [0u8; 8192];
    while Instant::now() < end && events.len() < 5 {
        events.append(&mut c.ready);
        if let Ok(n) = c.s.read(&mut buf) {
            let ready = &mut events;
            c.framer
                .feed(&buf[..n], |r| ready.push(r.unwrap().as_bytes().to_vec()));
        }
    }
    let got = |name: &str| -> Vec<Vec<u8>> {
        events
            .iter()
            .filter(|f| kind_of(f).1 == name)
            .cloned()
            .collect()
    };
    assert_eq!(got("LIDoutputstate"), capture_events("LIDoutputstate"));
    assert_eq!(got("LFErec"), capture_events("LFErec"));
    assert_eq!(emu.stop().events_sent, 5);
}

/// The start-up sequence SICK's driver (sick_scan_xd 3.9.0, LMS5xx launch file, binary)
/// sends: every answer is the capture's where the capture asked the same; the rest
/// (the probe before the login, FREchoFilter) is answered as the LMS5xx's telegram listing
/// says; then scans of 1141 points stream.
#[test]
fn sick_scan_xd_start_up_sequence_is_answered_as_the_lms511_answered() {
    let emu = Emulator::start(EmulatorConfig::default(), lms511_source()).unwrap();
    let mut c = Client::connect(&emu);
    let dialogue = capture_dialogue();
    let capture_answer = |req: &[u8]| {
        dialogue
            .iter()
            .find(|(r, _)| r == req)
            .map(|(_, a)| a.clone())
    };
    let emit = |r: Request<'_>| {
        let mut b = [0u8; 128];
        let n = r.emit(Dialect::ColaB, &mut b).unwrap();
        b[..n].to_vec()
    };
    let by_name = |name: &str| {
        dialogue
            .iter()
            .find(|(r, _)| kind_of(r).1 == name)
            .map(|(r, _)| r.clone())
            .unwrap()
    };
    let mut sequence: Vec<Vec<u8>> = vec![emit(Request::Read("SCdevicestate"))];
    for name in [
        "SetAccessMode",
        "EIHstCola",
        "FirmwareVersion",
        "SCdevicestate",
        "ODoprh",
        "ODpwrc",
        "LocationName",
    ] {
        sequence.push(by_name(name));
    }
    // LMPoutputRange read / write / read, the fields, LIDinputstate, LMDscandatacfg w / r.
    let capture_order: Vec<Vec<u8>> = dialogue.iter().map(|(r, _)| r.clone()).collect();
    let from = capture_order
        .iter()
        .position(|r| kind_of(r).1 == "LMPoutputRange")
        .unwrap();
    let to = capture_order
        .iter()
        .position(|r| kind_of(r).1 == "LMCstartmeas")
        .unwrap();
    sequence.extend(capture_order[from..to].iter().cloned());
    sequence.push(emit(Request::SetEchoFilter(lidar_driver::EchoFilter::All)));
    for name in ["LFErec", "LIDoutputstate", "LIDinputstate"] {
        sequence.push(emit(Request::Subscribe {
            event: name,
            enable: true,
        }));
    }
    for name in ["LMCstartmeas", "Run"] {
        sequence.push(by_name(name));
    }
    sequence.push(emit(Request::SUBSCRIBE_SCANS));
    // The probe, before the login: a device out of configuration mode says ready (the
    // capture asked only after the login, in configuration mode: busy).
    let probe = c.ask(&sequence[0]);
    let state = Answer::from_frame(lidar_driver::Frame::new_checked(&probe).unwrap());
    assert_eq!(
        state,
        Ok(Answer::DeviceState(lidar_driver::DeviceState::Ready))
    );
    let mut replayed = 0;
    for req in &sequence[1..] {
        let got = c.ask(req);
        let (kind, name) = kind_of(req);
        match capture_answer(req) {
            Some(want) => {
                assert_eq!(got, want, "{kind} {name}");
                replayed += 1;
            }
            None => {
                let a = Answer::from_frame(lidar_driver::Frame::new_checked(&got).unwrap());
                assert!(
                    !matches!(a, Ok(Answer::Error(_))),
                    "{kind} {name} refused: {a:?}"
                );
            }
        }
    }
    assert!(replayed >= 47, "{replayed}");
    // Scans follow, 1141 points each.
    let end = Instant::now() + Duration::from_secs(2);
    let mut scans = 0;
    let mut buf = [0u8; 16384];
    while Instant::now() < end && scans < 5 {
        let mut got = std::mem::take(&mut c.ready);
        if let Ok(n) = c.s.read(&mut buf) {
            c.framer
                .feed(&buf[..n], |r| got.push(r.unwrap().as_bytes().to_vec()));
        }
        for f in got {
            if let Ok(s) =
                lidar_driver::ScanData::new_checked(lidar_driver::Frame::new_checked(&f).unwrap())
            {
                assert_eq!(s.dist1().unwrap().len(), 1141);
                scans += 1;
            }
        }
    }
    assert!(scans >= 5, "{scans} scans");
}

#[test]
fn cola_a_answers_carry_the_same_values() {
    let emu = Emulator::start(EmulatorConfig::default(), lms511_source()).unwrap();
    let mut c = Client::connect(&emu);
    for (req_b, want_b) in capture_dialogue() {
        let (_, name) = kind_of(&req_b);
        if !typed(&name) {
            continue;
        }
        let r = Request::from_frame(lidar_driver::Frame::new_checked(&req_b).unwrap()).unwrap();
        let mut a = [0u8; 256];
        let n = r.emit(Dialect::ColaA, &mut a).unwrap();
        let got = c.ask(&a[..n]);
        let got_f = lidar_driver::Frame::new_checked(&got).unwrap();
        assert_eq!(got_f.dialect(), Dialect::ColaA);
        assert!(got[1..got.len() - 1]
            .iter()
            .all(|b| (0x20..0x7f).contains(b)));
        let want = Answer::from_frame(lidar_driver::Frame::new_checked(&want_b).unwrap()).unwrap();
        let got = Answer::from_frame(got_f).unwrap();
        assert_eq!(got, want, "{name}");
    }
}

#[test]
fn changes_need_a_login_and_unknown_names_are_refused() {
    let emu = Emulator::start(EmulatorConfig::default(), lms511_source()).unwrap();
    let mut c = Client::connect(&emu);
    let mut ask = |r: Request<'_>| {
        let mut b = [0u8; 256];
        let n = r.emit(Dialect::ColaB, &mut b).unwrap();
        let got = c.ask(&b[..n]);
        match Answer::from_frame(lidar_driver::Frame::new_checked(&got).unwrap()).unwrap() {
            Answer::Error(e) => Some(e),
            _ => None,
        }
    };
    assert_eq!(
        ask(Request::SetEchoFilter(lidar_driver::EchoFilter::All)),
        Some(SopasError::WriteAccessDenied)
    );
    assert_eq!(
        ask(Request::StartMeasurement),
        Some(SopasError::AccessDenied)
    );
    assert_eq!(
        ask(Request::Read("NoSuchVar")),
        Some(SopasError::UnknownVariable)
    );
    assert_eq!(ask(Request::Read("FirmwareVersion")), None);
    assert_eq!(
        ask(Request::login(lidar_driver::AccessLevel::AuthorizedClient)),
        None
    );
    assert_eq!(
        ask(Request::SetEchoFilter(lidar_driver::EchoFilter::All)),
        None
    );
    assert_eq!(ask(Request::StartMeasurement), None);
}

#[test]
fn busy_during_the_startup_delay() {
    let emu = Emulator::start(
        EmulatorConfig {
            startup_delay: Duration::from_millis(300),
            ..EmulatorConfig::default()
        },
        lms511_source(),
    )
    .unwrap();
    let mut c = Client::connect(&emu);
    let state = |c: &mut Client| {
        let mut b = [0u8; 64];
        let n = Request::Read("SCdevicestate")
            .emit(Dialect::ColaA, &mut b)
            .unwrap();
        c.ask(&b[..n])
    };
    assert_eq!(state(&mut c), b"\x02sRA SCdevicestate 0\x03");
    let mut b = [0u8; 64];
    let n = Request::login(lidar_driver::AccessLevel::AuthorizedClient)
        .emit(Dialect::ColaA, &mut b)
        .unwrap();
    assert_eq!(c.ask(&b[..n]), b"\x02sFA D\x03", "server busy (13)");
    std::thread::sleep(Duration::from_millis(350));
    assert_eq!(state(&mut c), b"\x02sRA SCdevicestate 1\x03");
}

#[test]
fn identity_from_a_recording_is_what_that_sensor_answered() {
    use lidar_driver::recording::Recording;
    use lms5xx_emulator::DeviceIdentity;
    let lms511 = Recording::read_file(capture(sick_captures::LMS511_JSON)).unwrap();
    assert_eq!(
        DeviceIdentity::from_recording(&lms511),
        DeviceIdentity::lms511_capture()
    );
    let lms111 = Recording::read_file(capture(sick_captures::LMS111_JSON)).unwrap();
    let id = DeviceIdentity::from_recording(&lms111);
    assert_eq!(id.firmware_version, b"V1.80.2  ");
    assert_eq!(id.location_name, b"not defined");
    assert_eq!(id.scan_config.frequency_1e2_hz, 5000);
    assert_eq!(id.scan_config.step_1e4_deg, 5000);
    assert_eq!(id.output_range.step_1e4_deg, 5000);
    assert_eq!(
        id.field_of_view_1e4_deg,
        (id.output_range.start_1e4_deg, id.output_range.stop_1e4_deg)
    );
    assert!(!id.scan_data.remission, "the LMS111 capture has no RSSI");
}

/// The answers and events built into the emulator (`data/lms511_start_up.pcapng.json`) are
/// exactly those of the LMS511 capture.
#[test]
fn the_built_in_answers_are_the_captures() {
    let rec =
        lidar_driver::recording::Recording::read_file(capture(sick_captures::LMS511_JSON)).unwrap();
    assert_eq!(
        lms5xx_emulator::RecordedAnswers::lms511_capture(),
        lms5xx_emulator::RecordedAnswers::from_recording(&rec)
    );
}
