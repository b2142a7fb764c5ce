//! The session over a serial line: a pty pair made by `socat`, the emulator's byte stream on
//! one end, the session's `SerialLink` on the other. Skipped (with a notice) only when `socat`
//! is not installed (`scripts/setup.sh` installs it).

mod session_support;

use std::io::{BufRead, BufReader};
use std::process::{Child, Command, Stdio};
use std::sync::mpsc;
use std::time::Duration;

use lidar_driver::session::{Session, SessionConfig};
use lidar_driver::transport::{SerialConfig, SerialLink};
use lidar_driver::Dialect;
use lms5xx_emulator::{DialectMode, Emulator, EmulatorConfig};

use session_support::*;

/// A socat process joining two ptys; killed on drop.
struct PtyPair {
    child: Child,
    a: String,
    b: String,
}

impl Drop for PtyPair {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

fn pty_pair() -> Option<PtyPair> {
    let mut child = match Command::new("socat")
        .args(["-d", "-d", "pty,raw,echo=0", "pty,raw,echo=0"])
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
    {
        Ok(c) => c,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return None,
        Err(e) => panic!("cannot run socat: {e}"),
    };
    let stderr = child.stderr.take().expect("piped stderr");
    let (tx, rx) = mpsc::channel();
    std::thread::spawn(move || {
        for line in BufReader::new(stderr).lines().map_while(Result::ok) {
            if let Some(p) = line.split("PTY is ").nth(1) {
                if tx.send(p.trim().to_string()).is_err() {
                    break;
                }
            }
        }
    });
    let mut names = Vec::new();
    while names.len() < 2 {
        match rx.recv_timeout(Duration::from_secs(5)) {
            Ok(n) => names.push(n),
            Err(_) => {
                let _ = child.kill();
                panic!("socat did not report two ptys");
            }
        }
    }
    let b = names.pop()?;
    let a = names.pop()?;
    Some(PtyPair { child, a, b })
}

fn over_pty(device: Dialect) {
    let Some(pair) = pty_pair() else {
        println!(
            "NOTICE: socat not installed, serial pty test skipped (scripts/setup.sh installs it)"
        );
        return;
    };
    let src = lms511_source();
    let expected = recorded_values(&src);
    let port = serialport::new(&pair.b, 115_200)
        .timeout(Duration::from_millis(2))
        .open()
        .expect("open emulator side of the pty");
    let emu = Emulator::start_on_stream(
        EmulatorConfig {
            dialect: DialectMode::Only(device),
            ..EmulatorConfig::default()
        },
        src,
        port,
    )
    .unwrap();
    let mut link = SerialLink::new(&pair.a, SerialConfig::new(115_200));
    let mut session = Session::new(
        vec![0u8; 16 * 1024],
        SessionConfig {
            first_dialect: Dialect::ColaB,
            ..fast_config()
        },
    );
    let seen = run(&mut session, &mut link, 15, Duration::from_secs(10));
    assert_eq!(seen.scans.len(), 15, "{:#?}", seen.log);
    assert_eq!(session.dialect(), Some(device));
    for (i, got) in seen.scans.iter().enumerate() {
        assert_eq!(got, &expected[i % expected.len()], "scan {i}");
    }
    assert_eq!(session.framer_stats().frames_bad(), 0);
    let es = emu.stop();
    assert!(es.scans_sent >= 15, "{es:?}");
}

#[test]
fn session_streams_over_a_serial_pty_in_cola_b() {
    over_pty(Dialect::ColaB);
}

#[test]
fn session_streams_over_a_serial_pty_in_cola_a() {
    over_pty(Dialect::ColaA);
}
