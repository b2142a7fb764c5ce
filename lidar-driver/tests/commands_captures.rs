//! The request encoder reproduces the captured host → sensor streams byte for byte, and the
//! answer parser types every captured sensor answer (re-encoding the typed ones exactly).

mod common;

use common::*;
use lidar_driver::{
    Answer, DeviceState, Dialect, Frame, OutputRange, Request, SessionConfig, Telegram,
};

#[test]
fn host_to_sensor_requests_are_reproduced_byte_for_byte() {
    for name in [LMS511_H2S, LMS111_H2S] {
        let stream = read(name);
        let frames = frames(&stream);
        assert_eq!(frames.len(), 49, "{name}");
        let mut rebuilt = Vec::new();
        for (d, bytes) in &frames {
            let req = Request::from_frame(Frame::new_checked(bytes).unwrap())
                .unwrap_or_else(|e| panic!("{name}: {e}: {bytes:02x?}"));
            let mut buf = [0u8; 256];
            let n = req.emit(*d, &mut buf).unwrap();
            assert_eq!(&buf[..n], &bytes[..], "{req:?}");
            rebuilt.extend_from_slice(&buf[..n]);
        }
        assert_eq!(rebuilt, stream, "{name}: whole stream identical");
    }
}

#[test]
fn captured_requests_have_the_expected_types() {
    let frames = frames(&read(LMS511_H2S));
    let reqs: Vec<Request<'_>> = frames
        .iter()
        .map(|(_, b)| Request::from_frame(Frame::new_checked(b).unwrap()).unwrap())
        .collect();
    assert_eq!(
        reqs[0],
        Request::SetAccessMode {
            level: 3,
            password: 0xF472_4744
        }
    );
    assert_eq!(reqs[1], Request::SetHostDialect(Dialect::ColaB));
    assert_eq!(reqs[2], Request::Read("FirmwareVersion"));
    assert_eq!(
        reqs[8],
        Request::SetOutputRange(OutputRange {
            sectors: 1,
            step_1e4_deg: 1667,
            start_1e4_deg: -50_000,
            stop_1e4_deg: 1_850_000
        })
    );
    assert!(reqs.contains(&Request::SetScanDataConfig(
        SessionConfig::CAPTURE_SCAN_DATA
    )));
    assert!(reqs.contains(&Request::StartMeasurement));
    assert!(reqs.contains(&Request::Run));
    assert!(reqs.contains(&Request::SUBSCRIBE_SCANS));
}

#[test]
fn sensor_answers_are_typed_and_re_encode_exactly() {
    for name in [LMS511_S2H, LMS111_S2H] {
        let mut seen = Vec::new();
        for (d, bytes) in frames(&read(name)) {
            let a = Answer::from_frame(Frame::new_checked(&bytes).unwrap())
                .unwrap_or_else(|e| panic!("{name}: {e}"));
            if !matches!(a, Answer::Scan(_)) {
                let mut buf = vec![0u8; 4096];
                let n = a.emit(d, &mut buf).unwrap();
                assert_eq!(&buf[..n], &bytes[..], "{a:?}");
            }
            seen.push(format!("{:?}", std::mem::discriminant(&a)));
            match a {
                Answer::AccessMode { accepted } => assert!(accepted),
                Answer::DeviceState(s) => assert_eq!(s, DeviceState::Busy),
                Answer::StartMeasurement { ok } => assert!(ok),
                Answer::Run { ok } => assert!(ok),
                Answer::OutputRange(r) => assert_eq!(r.sectors, 1),
                Answer::EventAck { enabled, .. } => assert!(enabled),
                Answer::Error(e) => panic!("no sFA in the captures: {e}"),
                _ => {}
            }
        }
        assert!(seen.len() > 100);
    }
    // The LMS511's documented answers.
    let fr = frames(&read(LMS511_S2H));
    let typed: Vec<Answer<'_>> = fr
        .iter()
        .map(|(_, b)| Answer::from_frame(Frame::new_checked(b).unwrap()).unwrap())
        .collect();
    assert!(typed.contains(&Answer::FirmwareVersion(b"V1.80    ")));
    assert!(typed.contains(&Answer::LocationName(b"SN 18110550")));
    assert!(typed.contains(&Answer::OutputRange(OutputRange {
        sectors: 1,
        step_1e4_deg: 0x683,
        start_1e4_deg: -50_000,
        stop_1e4_deg: 0x1C3A90
    })));
    assert!(typed
        .iter()
        .any(|a| matches!(a, Answer::WriteAck("LMDscandatacfg"))));
    assert!(typed
        .iter()
        .any(|a| matches!(a, Answer::Other(t) if t.name() == "field000")));
}

#[test]
fn sfa_errors_in_both_dialects() {
    use lidar_driver::SopasError;
    // CoLa-B: `sFA` then u16 with no space, as seen on the wire.
    let p = [b's', b'F', b'A', 0, 3];
    let mut b = vec![2, 2, 2, 2, 0, 0, 0, 5];
    b.extend_from_slice(&p);
    b.push(lidar_driver::xor_checksum(&p));
    let a = Answer::from_frame(Frame::new_checked(&b).unwrap()).unwrap();
    assert_eq!(a, Answer::Error(SopasError::UnknownVariable));
    let mut buf = [0u8; 32];
    let n = a.emit(Dialect::ColaB, &mut buf).unwrap();
    assert_eq!(&buf[..n], &b[..]);
    let a = Answer::from_frame(Frame::new_checked(b"\x02sFA 11\x03").unwrap()).unwrap();
    assert_eq!(a, Answer::Error(SopasError::ColaAInvalidCharacter));
    assert!(a_display(&a).contains("invalid character"));
    let n = a.emit(Dialect::ColaA, &mut buf).unwrap();
    assert_eq!(&buf[..n], b"\x02sFA 11\x03");
    let t = Telegram::parse(Frame::new_checked(b"\x02sFA 11\x03").unwrap()).unwrap();
    assert_eq!(t.name(), "");
}

fn a_display(a: &Answer<'_>) -> String {
    match a {
        Answer::Error(e) => e.to_string(),
        _ => String::new(),
    }
}

#[test]
fn cola_a_answers_parse_like_cola_b() {
    let cases: [(&[u8], Answer<'_>); 7] = [
        (
            b"\x02sAN SetAccessMode 1\x03",
            Answer::AccessMode { accepted: true },
        ),
        (
            b"\x02sRA SCdevicestate 1\x03",
            Answer::DeviceState(DeviceState::Ready),
        ),
        (
            b"\x02sRA LocationName B SN 18110550\x03",
            Answer::LocationName(b"SN 18110550"),
        ),
        (
            b"\x02sRA LMPoutputRange 1 683 FFFF3CB0 1C3A90\x03",
            Answer::OutputRange(OutputRange {
                sectors: 1,
                step_1e4_deg: 1667,
                start_1e4_deg: -50_000,
                stop_1e4_deg: 1_850_000,
            }),
        ),
        (
            b"\x02sAN mLMPsetscancfg 2\x03",
            Answer::SetScanConfig {
                result: Err(lidar_driver::ScanConfigError::Resolution),
                in_effect: None,
            },
        ),
        // The LMS500 operating instructions' example: accepted, with the parameters in effect.
        (
            b"\x02sAN mLMPsetscancfg 0 9C4 1 9C4 FFFF3CB0 1C3A90\x03",
            Answer::SetScanConfig {
                result: Ok(()),
                in_effect: Some(lidar_driver::ScanConfig {
                    frequency_1e2_hz: 2500,
                    sectors: 1,
                    step_1e4_deg: 2500,
                    start_1e4_deg: -50_000,
                    stop_1e4_deg: 1_850_000,
                }),
            },
        ),
        (
            b"\x02sEA LMDscandata 1\x03",
            Answer::EventAck {
                event: "LMDscandata",
                enabled: true,
            },
        ),
    ];
    for (bytes, want) in cases {
        let a = Answer::from_frame(Frame::new_checked(bytes).unwrap()).unwrap();
        assert_eq!(a, want);
        let mut buf = [0u8; 64];
        let n = a.emit(Dialect::ColaA, &mut buf).unwrap();
        assert_eq!(&buf[..n], bytes);
        let n = a.emit(Dialect::ColaB, &mut buf).unwrap();
        assert_eq!(
            Answer::from_frame(Frame::new_checked(&buf[..n]).unwrap()).unwrap(),
            want
        );
    }
}
