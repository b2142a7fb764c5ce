//! `sick-dump`: print the telegrams of a SICK recording (raw CoLa stream, pcap, pcapng or
//! SICK `.pcapng.json`; the format is detected from content) as a table or as JSON lines.
//!
//! ```text
//! sick-dump FILE                   one row per telegram
//! sick-dump --format jsonl FILE    one JSON object per scan
//! sick-dump --stats FILE           frames seen, good, bad by cause, scans, answers by type
//! ```

use std::collections::BTreeMap;
use std::io::{self, BufWriter, Write};
use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, ValueEnum};
use lidar_driver::framer::FramerStats;
use lidar_driver::recording::{Direction, FrameReader, RecordingError, RecordingReader};
use lidar_driver::{Answer, Request, ScanData, Telegram};
use scan_input::BeamLayout;

/// Output formats.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
enum Format {
    /// One human-readable row per telegram.
    Table,
    /// One JSON object per scan.
    Jsonl,
}

/// Dump a SICK LMS5xx / TiM recording: raw CoLa-A/CoLa-B bytes, pcap, pcapng or SICK .pcapng.json.
#[derive(Debug, Parser)]
#[command(name = "sick-dump", version)]
struct Cli {
    /// Recording file.
    file: PathBuf,
    /// Output format.
    #[arg(long, value_enum, default_value_t = Format::Table)]
    format: Format,
    /// Print counters: frames seen, good, bad by cause, scans, answers and requests by type
    /// (to stderr with `--format jsonl`, so stdout stays JSON lines).
    #[arg(long)]
    stats: bool,
    /// Table only: print just the summary counters, not the rows.
    #[arg(long, requires = "stats")]
    quiet: bool,
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let mut reader = match RecordingReader::open(&cli.file) {
        Ok(r) => r,
        Err(e) => {
            eprintln!("sick-dump: {}: {e}", cli.file.display());
            return ExitCode::FAILURE;
        }
    };
    let stdout = io::stdout();
    let mut out = BufWriter::new(stdout.lock());
    // The file is streamed: memory stays at its largest record, whatever its size.
    let result = run(&cli, &mut reader, &mut out).and_then(|r| out.flush().map(|_| r));
    // A damaged file is read around its damage: say where (the rest was dumped).
    for d in reader.damage() {
        eprintln!("sick-dump: {}: {d}", cli.file.display());
    }
    match result {
        Ok(Ok(())) => ExitCode::SUCCESS,
        Ok(Err(e)) => {
            eprintln!("sick-dump: {}: {e}", cli.file.display());
            ExitCode::FAILURE
        }
        // A closed pipe (`| head`) is not an error.
        Err(e) if e.kind() == io::ErrorKind::BrokenPipe => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("sick-dump: {e}");
            ExitCode::FAILURE
        }
    }
}

#[derive(Default)]
struct Counts {
    scans: u64,
    scan_errors: u64,
    by_type: BTreeMap<String, u64>,
    not_telegrams: u64,
}

/// Dumps the frames; the outer error is the output's, the inner the recording's.
fn run<R: io::Read>(
    cli: &Cli,
    reader: &mut RecordingReader<R>,
    out: &mut impl Write,
) -> io::Result<Result<(), RecordingError>> {
    let mut counts = Counts::default();
    if cli.format == Format::Table && !cli.quiet {
        writeln!(
            out,
            "{:>5} {:>10} {:<3} {:<6} {:<4} {:<16} details",
            "#", "time_s", "dir", "dialect", "type", "name"
        )?;
    }
    let mut frames = FrameReader::new(|| reader.next_chunk());
    let mut i = 0usize;
    loop {
        let f = match frames.next_frame() {
            Ok(Some(Ok(f))) => f,
            Ok(Some(Err(_))) => continue,
            Ok(None) => break,
            Err(e) => return Ok(Err(e)),
        };
        i += 1;
        let i = i - 1;
        let Ok(t) = Telegram::parse(f.frame()) else {
            counts.not_telegrams += 1;
            continue;
        };
        *counts
            .by_type
            .entry(t.kind().as_str().to_string())
            .or_default() += 1;
        let scan = ScanData::is_scan_telegram(&t).then(|| ScanData::from_telegram(&t));
        match &scan {
            Some(Ok(_)) => counts.scans += 1,
            Some(Err(_)) => counts.scan_errors += 1,
            None => {}
        }
        match cli.format {
            Format::Jsonl => {
                if let Some(Ok(s)) = &scan {
                    writeln!(out, "{}", scan_json(s, f.time_s))?;
                }
            }
            Format::Table if !cli.quiet => {
                let dir = match f.direction {
                    Direction::HostToSensor => "h>s",
                    Direction::SensorToHost => "s>h",
                    Direction::Unknown => "?",
                };
                let time = f.time_s.map_or("-".to_string(), |t| format!("{t:.6}"));
                let details = match &scan {
                    Some(Ok(s)) => scan_summary(s),
                    Some(Err(e)) => format!("DECODE ERROR: {e}"),
                    None if t.kind().is_request() => match Request::parse(&t) {
                        Ok(r) => format!("{r:?}"),
                        Err(_) => format!("{} argument bytes", t.args().len()),
                    },
                    None => match Answer::parse(&t) {
                        Ok(Answer::Other(o)) => format!("{} argument bytes", o.args().len()),
                        Ok(a) => answer_summary(&a),
                        Err(e) => format!("ERROR: {e}"),
                    },
                };
                writeln!(
                    out,
                    "{:>5} {:>10} {:<3} {:<6} {:<4} {:<16} {}",
                    i,
                    time,
                    dir,
                    f.dialect.name(),
                    t.kind().as_str(),
                    t.name(),
                    details
                )?;
            }
            Format::Table => {}
        }
    }
    let framer = frames.stats();
    drop(frames);
    if cli.stats {
        let text = stats_text(reader, &framer, &counts);
        if cli.format == Format::Jsonl {
            eprint!("{text}");
        } else {
            write!(out, "{text}")?;
        }
    }
    Ok(Ok(()))
}

fn answer_summary(a: &Answer<'_>) -> String {
    let text = |b: &[u8]| String::from_utf8_lossy(b).into_owned();
    match a {
        Answer::FirmwareVersion(v) => format!("FirmwareVersion({:?})", text(v)),
        Answer::LocationName(v) => format!("LocationName({:?})", text(v)),
        Answer::Error(e) => format!("{e}"),
        other => format!("{other:?}"),
    }
}

fn scan_summary(s: &ScanData<'_>) -> String {
    let h = &s.header;
    let mut line = format!(
        "scan {} tel {} serial {} status {:02X} {:02X} {} Hz",
        h.scan_counter,
        h.telegram_counter,
        h.serial_number,
        h.device_status[0],
        h.device_status[1],
        h.scan_frequency_hz()
    );
    for c in s.channels() {
        let hd = &c.header;
        line.push_str(&format!(
            " | {} {}x{}bit {:.4}..{:.4} deg",
            c.name(),
            c.len(),
            c.bits().bytes() * 8,
            hd.angle_deg(0),
            hd.angle_deg(c.len().saturating_sub(1))
        ));
    }
    line
}

fn scan_json(s: &ScanData<'_>, time_s: Option<f64>) -> serde_json::Value {
    let h = &s.header;
    let channels: Vec<serde_json::Value> = s
        .channels()
        .map(|c| {
            serde_json::json!({
                "name": c.name(),
                "bits": c.bits().bytes() * 8,
                "count": c.len(),
                "start_angle_deg": c.header.start_angle_1e4_deg as f64 / 10_000.0,
                "step_deg": c.header.step_1e4_deg as f64 / 10_000.0,
                // The step scan-input (the one telegram-to-scan conversion) uses: exact from
                // the scan and shot frequencies when that rounds to the telegram's step.
                "beam_step_deg": BeamLayout::of(h, &c.header).step_used_1e4_deg() / 10_000.0,
                "scale_factor": c.header.scale_factor,
                "scale_offset": c.header.scale_offset,
                "values": c.values().collect::<Vec<u16>>(),
            })
        })
        .collect();
    serde_json::json!({
        "time_s": time_s,
        "scan_counter": h.scan_counter,
        "telegram_counter": h.telegram_counter,
        "serial_number": h.serial_number,
        "device_status": h.device_status,
        "scan_frequency_hz": h.scan_frequency_1e2_hz as f64 / 100.0,
        "measurement_frequency_hz": h.measurement_frequency_100hz as f64 * 100.0,
        "time_since_startup_us": h.time_since_startup_us,
        "time_of_transmission_us": h.time_of_transmission_us,
        "channels": channels,
    })
}

fn stats_text<R: io::Read>(rec: &RecordingReader<R>, s: &FramerStats, c: &Counts) -> String {
    let mut t = String::new();
    t.push_str(&format!("format: {:?}\n", rec.format()));
    for d in rec.damage() {
        t.push_str(&format!("file {d}\n"));
    }
    t.push_str(&format!(
        "bytes: {}  garbage bytes: {}\n",
        s.bytes_in, s.garbage_bytes
    ));
    t.push_str(&format!(
        "frames seen: {}  good: {} (CoLa-A {}, CoLa-B {})  bad: {} (checksum {}, length {}, oversize {}, truncated {})\n",
        s.frames_good() + s.frames_bad(),
        s.frames_good(),
        s.frames_cola_a,
        s.frames_cola_b,
        s.frames_bad(),
        s.bad_checksum,
        s.bad_length,
        s.oversize,
        s.truncated
    ));
    t.push_str(&format!(
        "scans: {}  scan decode errors: {}\n",
        c.scans, c.scan_errors
    ));
    let join = |answers: bool| {
        c.by_type
            .iter()
            .filter(|(k, _)| {
                lidar_driver::CommandType::from_bytes(k.as_bytes())
                    .is_some_and(|t| t.is_request() != answers)
            })
            .map(|(k, v)| format!("{k} {v}"))
            .collect::<Vec<_>>()
            .join(", ")
    };
    t.push_str(&format!("answers by type: {}\n", join(true)));
    t.push_str(&format!("requests by type: {}\n", join(false)));
    if c.not_telegrams > 0 {
        t.push_str(&format!(
            "frames without a SOPAS command type: {}\n",
            c.not_telegrams
        ));
    }
    if let Some(tcp) = rec.tcp_stats() {
        t.push_str(&format!(
            "tcp: packets {}, non-TCP {}, segments {}, retransmissions dropped {}, out of order {}, gaps {}\n",
            tcp.packets, tcp.skipped, tcp.segments, tcp.retransmissions, tcp.out_of_order, tcp.gaps
        ));
    }
    t
}
