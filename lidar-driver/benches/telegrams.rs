//! Decoder and framer speed on the real LMS511 capture.
//!
//! `cargo bench -p lidar-driver --bench telegrams -- --warm-up-time 1 --measurement-time 3`
//! Targets: ≥ 200,000 scans/s from CoLa-B, ≥ 20,000 scans/s from CoLa-A (one core), framer
//! ≥ 1 GB/s on a clean stream. Times are the benchmark thread's CPU time (see `cpu_clock`).

use std::hint::black_box;

mod cpu_clock;

use cpu_clock::ThreadCpuTime;
use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use lidar_driver::{Dialect, Frame, Framer, ScanData, ScanRepr};

fn capture() -> Vec<u8> {
    sick_captures::read(sick_captures::LMS511_S2H)
}

/// The first scan of the capture, as captured (CoLa-B) and re-encoded as CoLa-A.
fn first_scan(stream: &[u8]) -> (Vec<u8>, Vec<u8>) {
    let mut f = Framer::new(vec![0u8; 64 * 1024]);
    let mut scan = None;
    f.feed(stream, |r| {
        if let Ok(fr) = r {
            if scan.is_none() && ScanData::new_checked(fr).is_ok() {
                scan = Some(fr.as_bytes().to_vec());
            }
        }
    });
    let b = scan.expect("a scan");
    let s = ScanData::new_checked(Frame::new_checked(&b).unwrap()).unwrap();
    let a = ScanRepr::parse(&s).to_vec(Dialect::ColaA).unwrap();
    (b, a)
}

/// Decode (frame check + every field checked) and sum the DIST1 distances in mm.
fn decode_and_sum(bytes: &[u8]) -> f32 {
    let s = ScanData::new_checked(Frame::new_checked(bytes).unwrap()).unwrap();
    s.dist1().unwrap().distances_mm().flatten().sum()
}

fn benches(c: &mut Criterion<ThreadCpuTime>) {
    let stream = capture();
    let (colab, colaa) = first_scan(&stream);

    let mut g = c.benchmark_group("lms511_scan");
    g.throughput(Throughput::Elements(1));
    g.bench_function("decode_cola_b", |b| {
        b.iter(|| {
            ScanData::new_checked(Frame::new_checked(black_box(&colab)).unwrap())
                .unwrap()
                .header
                .scan_counter
        })
    });
    g.bench_function("decode_cola_b_sum_dist1", |b| {
        b.iter(|| decode_and_sum(black_box(&colab)))
    });
    g.bench_function("decode_cola_a", |b| {
        b.iter(|| {
            ScanData::new_checked(Frame::new_checked(black_box(&colaa)).unwrap())
                .unwrap()
                .header
                .scan_counter
        })
    });
    g.bench_function("decode_cola_a_sum_dist1", |b| {
        b.iter(|| decode_and_sum(black_box(&colaa)))
    });
    let repr =
        ScanRepr::parse(&ScanData::new_checked(Frame::new_checked(&colab).unwrap()).unwrap());
    let mut out = vec![0u8; 32 * 1024];
    g.bench_function("emit_cola_b", |b| {
        b.iter(|| repr.emit(Dialect::ColaB, black_box(&mut out)).unwrap())
    });
    g.bench_function("emit_cola_a", |b| {
        b.iter(|| repr.emit(Dialect::ColaA, black_box(&mut out)).unwrap())
    });
    g.finish();

    let mut g = c.benchmark_group("framer");
    g.throughput(Throughput::Bytes(stream.len() as u64));
    g.bench_function("clean_lms511_stream_64k_chunks", |b| {
        let mut framer = Framer::new(vec![0u8; 256 * 1024]);
        b.iter(|| {
            let mut n = 0usize;
            for chunk in stream.chunks(64 * 1024) {
                framer.feed(chunk, |r| n += r.map_or(0, |f| f.as_bytes().len()));
            }
            assert_eq!(n, stream.len());
            n
        })
    });
    g.finish();
}

criterion_group! {
    name = telegram_benches;
    config = Criterion::default().with_measurement(ThreadCpuTime);
    targets = benches
}
criterion_main!(telegram_benches);
