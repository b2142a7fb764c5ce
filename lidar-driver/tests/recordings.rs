//! Recording readers on the real captures: SICK JSON, raw streams, a real pcapng with telegrams
//! split over TCP segments, and pcap with retransmitted and reordered segments.

mod common;

use common::*;
use lidar_driver::recording::{capture_packets, write_pcap, Direction, Recording, RecordingFormat};
use lidar_driver::{ChannelBits, Request, ScanData, ScanRepr, Telegram};

fn scans(rec: &Recording) -> Vec<ScanRepr> {
    let frames = rec.frames();
    assert!(frames.errors.is_empty(), "{:?}", frames.errors);
    frames
        .frames
        .iter()
        .filter_map(|f| {
            let t = Telegram::parse(f.frame()).ok()?;
            ScanData::is_scan_telegram(&t).then(|| {
                assert_eq!(f.direction, Direction::SensorToHost);
                ScanRepr::parse(&ScanData::from_telegram(&t).expect("every scan decodes"))
            })
        })
        .collect()
}

#[test]
fn lms511_json_and_raw_stream_give_the_same_174_scans() {
    let json = Recording::read_file(capture(LMS511_JSON)).unwrap();
    assert_eq!(json.format, RecordingFormat::SickJson);
    let raw = Recording::read_file(capture(LMS511_S2H)).unwrap();
    assert_eq!(raw.format, RecordingFormat::Raw);
    let a = scans(&json);
    let b = scans(&raw);
    assert_eq!(a.len(), 174);
    assert_eq!(a, b);
    assert_eq!(a[0].header.serial_number, 18_110_550);
    assert_eq!(a[0].channels16[0].values.len(), 1141);
    // The JSON holds the requests too, classified as host → sensor by command type.
    let frames = json.frames();
    let requests: Vec<_> = frames
        .frames
        .iter()
        .filter(|f| f.direction == Direction::HostToSensor)
        .map(|f| Request::from_frame(f.frame()).unwrap())
        .collect();
    assert_eq!(requests.len(), 49);
    assert_eq!(
        requests[0],
        Request::SetAccessMode {
            level: 3,
            password: 0xF472_4744
        }
    );
    assert!(frames.frames.iter().all(|f| f.time_s.is_some()));
}

#[test]
fn lms111_json_has_175_scans() {
    let json = Recording::read_file(capture(LMS111_JSON)).unwrap();
    let s = scans(&json);
    assert_eq!(s.len(), 175);
    assert!(s
        .iter()
        .all(|s| s.header.version == 1 && s.channels16[0].values.len() == 541));
}

fn check_tim(s: &[ScanRepr]) {
    assert_eq!(s.len(), 16);
    for scan in s {
        assert_eq!(scan.header.serial_number, 18_480_390);
        assert_eq!(scan.header.scan_frequency_1e2_hz, 1500);
        assert_eq!(scan.channels16.len(), 2, "DIST1 and RSSI1, both 16-bit");
        assert_eq!(scan.channels16[0].values.len(), 811);
        assert_eq!(&scan.channels16[1].name, b"RSSI1");
        assert_eq!(scan.channels16[1].values.len(), 811);
        assert!(scan.channels8.is_empty());
    }
    for w in s.windows(2) {
        assert_eq!(
            w[1].header.scan_counter,
            w[0].header.scan_counter.wrapping_add(1)
        );
    }
}

#[test]
fn tim_pcapng_reassembles_split_telegrams() {
    let rec = Recording::read_file(capture(TIM_PCAPNG)).unwrap();
    assert_eq!(rec.format, RecordingFormat::Pcapng);
    let s = scans(&rec);
    check_tim(&s);
    let raw = std::fs::read(capture(TIM_PCAPNG)).unwrap();
    let frames = rec.frames();
    let t = Telegram::parse(
        frames
            .frames
            .iter()
            .find(|f| f.bytes.len() > 3000)
            .unwrap()
            .frame(),
    )
    .unwrap();
    let sd = ScanData::from_telegram(&t).unwrap();
    assert_eq!(sd.channel("RSSI1").unwrap().bits(), ChannelBits::U16);
    assert!(
        capture_packets(&raw).unwrap().len() >= 32,
        "each telegram spans two segments"
    );
}

#[test]
fn pcap_with_retransmissions_and_reordering_gives_the_same_scans() {
    let raw = std::fs::read(capture(TIM_PCAPNG)).unwrap();
    let mut packets = capture_packets(&raw).unwrap();
    let clean = Recording::parse(&write_pcap(&packets)).unwrap();
    assert_eq!(clean.format, RecordingFormat::Pcap);
    check_tim(&scans(&clean));
    // Retransmit every 5th data packet and swap two neighbours further on.
    let data_idx: Vec<usize> = (0..packets.len())
        .filter(|&i| packets[i].data.len() > 100)
        .collect();
    let (a, b) = (data_idx[6], data_idx[7]);
    packets.swap(a, b);
    let mut messy = Vec::new();
    for (i, p) in packets.iter().enumerate() {
        messy.push(p.clone());
        if data_idx.contains(&i) && i % 5 == 0 {
            messy.push(p.clone());
        }
    }
    let rec = Recording::parse(&write_pcap(&messy)).unwrap();
    let tcp = rec.tcp.unwrap();
    assert!(tcp.retransmissions > 0, "{tcp:?}");
    assert!(tcp.out_of_order > 0, "{tcp:?}");
    check_tim(&scans(&rec));
}

/// The scans of a damaged recording that decode (frames the framer drops are not counted).
fn intact_scans(rec: &Recording) -> usize {
    rec.frames()
        .frames
        .iter()
        .filter(|f| ScanData::new_checked(f.frame()).is_ok())
        .count()
}

/// The end offset of every block of a pcapng file.
fn block_ends(b: &[u8]) -> Vec<usize> {
    let mut ends = Vec::new();
    let mut at = 0;
    while at + 8 <= b.len() {
        let len = u32::from_le_bytes(b[at + 4..at + 8].try_into().unwrap()) as usize;
        at += len;
        ends.push(at);
    }
    ends
}

/// A pcapng cut at any byte keeps every scan whose blocks are complete: exactly the scans of
/// the file cut at its last whole block before the cut, and the cut is reported.
#[test]
fn a_pcapng_cut_anywhere_keeps_the_scans_of_its_complete_blocks() {
    let full = read(TIM_PCAPNG);
    let ends = block_ends(&full);
    assert_eq!(*ends.last().unwrap(), full.len());
    let mut checked = 0;
    for cut in (1..full.len())
        .step_by(97)
        .chain(ends.iter().flat_map(|&e| [e - 1, e, e + 1]))
    {
        if cut >= full.len() || cut < 32 {
            continue;
        }
        let whole = ends
            .iter()
            .copied()
            .filter(|&e| e <= cut)
            .max()
            .unwrap_or(0);
        let Ok(expected) = Recording::parse(&full[..whole]) else {
            continue; // not even the section header: nothing to keep
        };
        let got = Recording::parse(&full[..cut]).unwrap();
        assert_eq!(intact_scans(&got), intact_scans(&expected), "cut at {cut}");
        assert_eq!(
            got.damage.is_empty(),
            cut == whole,
            "cut at {cut}: {:?}",
            got.damage
        );
        checked += 1;
    }
    assert!(checked > 600, "{checked}");
}

/// One bad block length in the middle loses the packets of that block only: reading resumes
/// at the next block, and the damage is reported with its offset.
#[test]
fn a_bad_block_length_loses_only_that_block() {
    let mut b = read(TIM_PCAPNG);
    let ends = block_ends(&b);
    let at = ends[ends.len() / 2];
    b[at + 4..at + 8].copy_from_slice(&7u32.to_le_bytes());
    let rec = Recording::parse(&b).unwrap();
    assert_eq!(rec.damage.len(), 1, "{:?}", rec.damage);
    assert_eq!(rec.damage[0].offset, at);
    let n = intact_scans(&rec);
    // 16 scans, each over two TCP segments: at most the one telegram of the lost block.
    assert!((15..=16).contains(&n), "{n}");
}

/// A SICK `.pcapng.json` cut in the middle keeps its complete records.
#[test]
fn a_truncated_sick_json_keeps_its_complete_records() {
    let b = read(LMS511_JSON);
    let cut = b.len() / 2;
    let rec = Recording::parse(&b[..cut]).unwrap();
    assert_eq!(rec.damage.len(), 1, "{:?}", rec.damage);
    assert!(rec.damage[0].to_string().contains("cut short"));
    let n = intact_scans(&rec);
    assert!((80..174).contains(&n), "{n}");
    // Every scan kept is one of the full file's, in order.
    let full = Recording::parse(&b).unwrap().frames().frames;
    let kept = rec.frames().frames;
    for (a, k) in full.iter().zip(&kept) {
        assert_eq!(a.bytes, k.bytes);
    }
}

/// The streamed read of every real capture, fed 7 bytes at a time, gives the frames of the
/// in-memory read, in order, with their times and directions.
#[test]
fn streaming_gives_the_in_memory_frames_of_every_capture() {
    use lidar_driver::recording::{FrameReader, RecordingReader};
    for name in [LMS511_JSON, LMS511_S2H, LMS111_JSON, TIM_PCAPNG] {
        let bytes = std::fs::read(capture(name)).unwrap();
        let whole = Recording::parse(&bytes).unwrap().frames();
        let mut reader = RecordingReader::new(Trickle {
            rest: &bytes,
            step: 7,
        })
        .unwrap();
        let mut frames = FrameReader::new(move || reader.next_chunk());
        let mut got = Vec::new();
        let mut errors = 0usize;
        while let Some(item) = frames.next_frame().unwrap() {
            match item {
                Ok(f) => got.push(f),
                Err(_) => errors += 1,
            }
        }
        assert_eq!(got, whole.frames, "{name}");
        assert_eq!(errors, whole.errors.len(), "{name}");
        assert_eq!(frames.stats(), whole.stats, "{name}");
        assert!(got.len() > 15, "{name}: {}", got.len());
    }
}
