//! Every scan of the real LMS511 / LMS111 captures decodes, with the values the notes state.

mod common;

use common::*;
use lidar_driver::{
    Answer, ChannelBits, Frame, ScanData, ScanError, ScanField, ScanRepr, Telegram,
};

fn scans(name: &str) -> Vec<Vec<u8>> {
    frames(&read(name))
        .into_iter()
        .map(|(_, b)| b)
        .filter(|b| {
            let t = Telegram::parse(Frame::new_checked(b).unwrap()).unwrap();
            ScanData::is_scan_telegram(&t)
        })
        .collect()
}

#[test]
fn lms511_all_174_scans_decode_with_the_documented_values() {
    let scans = scans(LMS511_S2H);
    assert_eq!(scans.len(), 174);
    let mut last_counter = None;
    for (i, bytes) in scans.iter().enumerate() {
        let s = ScanData::new_checked(Frame::new_checked(bytes).unwrap()).unwrap();
        assert_eq!(s.header.serial_number, 18_110_550);
        assert_eq!(s.header.version, 0);
        assert_eq!(s.header.scan_frequency_1e2_hz, 2500);
        assert_eq!(s.header.measurement_frequency_100hz, 540);
        assert_eq!(s.header.device_status, if i == 0 { [1, 0] } else { [0, 0] });
        if let Some(prev) = last_counter {
            assert_eq!(s.header.scan_counter, u16::wrapping_add(prev, 1));
        }
        last_counter = Some(s.header.scan_counter);
        assert_eq!(s.channels16().len(), 1);
        assert_eq!(s.channels8().len(), 1);
        let d = s.dist1().unwrap();
        assert_eq!(d.len(), 1141);
        assert_eq!(d.header.start_angle_1e4_deg, -50_000);
        assert_eq!(d.header.step_1e4_deg, 1667);
        assert_eq!(d.header.scale_factor, 1.0);
        assert_eq!(d.header.scale_offset, 0.0);
        assert_eq!(d.values().count(), 1141);
        let rssi = s.channel("RSSI1").unwrap();
        assert_eq!(rssi.bits(), ChannelBits::U8);
        assert_eq!(rssi.len(), 1141);
        assert!(s.time().is_some());
        assert!(s.position().is_none() && s.device_name().is_none() && s.comment().is_none());
        assert!(s.event().is_none());
    }
    let first = ScanData::new_checked(Frame::new_checked(&scans[0]).unwrap()).unwrap();
    let h = first.header;
    let dt_us = h.time_of_transmission_us - h.time_since_startup_us;
    assert_eq!(
        dt_us / 10,
        4085,
        "time of transmission - time since start-up = 40.85 ms"
    );
    let d = first.dist1().unwrap();
    assert!((d.header.angle_deg(1140) - 185.038).abs() < 1e-9);
    // Scale applied: distances in mm and m agree with the raw values (factor 1, offset 0).
    let raw0 = d.get(0).unwrap();
    assert_eq!(raw0, 0x0519);
    assert_eq!(d.distances_mm().next().unwrap(), Some(1305.0));
    assert!((d.ranges_m().next().unwrap().unwrap() - 1.305).abs() < 1e-6);
    let t = first.time().unwrap();
    assert_eq!(
        (t.year, t.month, t.day, t.hour, t.minute, t.second),
        (1970, 1, 1, 3, 31, 30)
    );
}

#[test]
fn lms111_all_175_scans_decode() {
    let scans = scans(LMS111_S2H);
    assert_eq!(scans.len(), 175);
    let mut counters = Vec::new();
    for bytes in &scans {
        let s = ScanData::new_checked(Frame::new_checked(bytes).unwrap()).unwrap();
        assert_eq!(s.header.version, 1);
        assert_eq!(s.header.serial_number, 18_090_362);
        assert_eq!(s.header.scan_frequency_1e2_hz, 5000);
        assert_eq!(s.channels16().len(), 1);
        assert_eq!(s.channels8().len(), 0);
        let d = s.dist1().unwrap();
        assert_eq!(d.len(), 541);
        assert_eq!(d.header.start_angle_1e4_deg, -450_000);
        assert_eq!(d.header.step_1e4_deg, 5000);
        counters.push(s.header.scan_counter);
    }
    let mut sorted = counters.clone();
    sorted.sort_unstable();
    sorted.dedup();
    assert_eq!(
        counters.len() - sorted.len(),
        3,
        "3 scan counters repeat (retransmissions)"
    );
}

#[test]
fn every_scan_re_encodes_byte_identical_in_cola_b_and_round_trips_through_cola_a() {
    for name in [LMS511_S2H, LMS111_S2H] {
        for bytes in scans(name) {
            let s = ScanData::new_checked(Frame::new_checked(&bytes).unwrap()).unwrap();
            let repr = ScanRepr::parse(&s);
            assert_eq!(repr.to_vec(lidar_driver::Dialect::ColaB).unwrap(), bytes);
            let a = repr.to_vec(lidar_driver::Dialect::ColaA).unwrap();
            let fa = Frame::new_checked(&a).unwrap();
            assert_eq!(fa.dialect(), lidar_driver::Dialect::ColaA);
            let sa = ScanData::new_checked(fa).unwrap();
            assert_eq!(sa.header, s.header);
            assert_eq!(ScanRepr::parse(&sa), repr);
            // Zero-copy iterators agree value by value in both dialects.
            for (cb, ca) in s.channels().zip(sa.channels()) {
                assert_eq!(cb.header, ca.header);
                assert!(cb.values().eq(ca.values()));
            }
        }
    }
}

#[test]
fn errors_name_the_field_and_offset() {
    let bytes = scans(LMS511_S2H).remove(0);
    // Cut the frame inside the DIST1 header and re-frame it as a valid CoLa-B frame.
    let payload = &bytes[8..70];
    let mut cut = vec![2, 2, 2, 2];
    cut.extend_from_slice(&(payload.len() as u32).to_be_bytes());
    cut.extend_from_slice(payload);
    cut.push(lidar_driver::xor_checksum(payload));
    let e = ScanData::new_checked(Frame::new_checked(&cut).unwrap()).unwrap_err();
    assert_eq!(
        e,
        ScanError::Field {
            field: ScanField::ScaleFactor,
            offset: 69,
            kind: lidar_driver::ArgErrorKind::Truncated
        }
    );
    assert!(e.to_string().contains("scale factor"));
    // A non-scan telegram is refused with its type.
    let f = frames(&read(LMS511_S2H)).remove(0).1;
    assert!(matches!(
        ScanData::new_checked(Frame::new_checked(&f).unwrap()),
        Err(ScanError::NotScanData { .. })
    ));
    assert!(matches!(
        Answer::from_frame(Frame::new_checked(&f).unwrap()),
        Ok(Answer::AccessMode { accepted: true })
    ));
}
