//! Idle connections cost the emulator next to nothing: with 50 of them open its threads sleep
//! in their reads instead of waking every few milliseconds. Alone in its test binary, so the
//! process's CPU time is the emulator's (Linux: read from `/proc`).
#![cfg(target_os = "linux")]

mod session_support;

use std::io::{Read, Write};
use std::net::TcpStream;
use std::time::{Duration, Instant};

use lidar_driver::{Dialect, Framer, Request};
use lms5xx_emulator::{Emulator, EmulatorConfig, Limits};

use session_support::lms511_source;

/// User + system CPU time of this process, in clock ticks (`/proc/self/stat` fields 14 and
/// 15; Linux reports them in USER_HZ = 100 per second).
fn cpu_ticks() -> u64 {
    let stat = std::fs::read_to_string("/proc/self/stat").unwrap();
    // Fields after the command name, which is in parentheses and may hold spaces.
    let after = &stat[stat.rfind(')').unwrap() + 2..];
    let f: Vec<&str> = after.split_whitespace().collect();
    // `after` starts at field 3 (state): utime is field 14, stime field 15.
    f[11].parse::<u64>().unwrap() + f[12].parse::<u64>().unwrap()
}

const USER_HZ: f64 = 100.0;

/// Context switches of all threads of this process: how often they went to sleep and woke.
fn context_switches() -> u64 {
    let mut n = 0;
    for task in std::fs::read_dir("/proc/self/task").unwrap() {
        let path = task.unwrap().path().join("status");
        // A thread that ended meanwhile has no status: it did not switch in the window.
        let Ok(status) = std::fs::read_to_string(path) else {
            continue;
        };
        for line in status.lines() {
            if let Some(v) = line
                .strip_prefix("voluntary_ctxt_switches:")
                .or_else(|| line.strip_prefix("nonvoluntary_ctxt_switches:"))
            {
                n += v.trim().parse::<u64>().unwrap();
            }
        }
    }
    n
}

/// Sends `sRN FirmwareVersion` and waits for the answer.
fn ask(s: &mut TcpStream) {
    let mut b = [0u8; 64];
    let n = Request::Read("FirmwareVersion")
        .emit(Dialect::ColaB, &mut b)
        .unwrap();
    s.write_all(&b[..n]).unwrap();
    let mut framer = Framer::new(vec![0u8; 4096]);
    let mut got = 0;
    let end = Instant::now() + Duration::from_secs(3);
    while got == 0 {
        assert!(Instant::now() < end, "no answer");
        let n = s.read(&mut b).unwrap();
        assert!(n > 0, "connection closed");
        framer.feed(&b[..n], |r| got += usize::from(r.is_ok()));
    }
}

#[test]
fn fifty_idle_connections_cost_no_cpu_to_speak_of() {
    let config = EmulatorConfig {
        limits: Limits {
            max_connections: 64,
            ..Limits::default()
        },
        ..EmulatorConfig::default()
    };
    let emu = Emulator::start(config, lms511_source()).unwrap();
    let mut conns: Vec<TcpStream> = (0..50)
        .map(|_| TcpStream::connect(emu.addr().unwrap()).unwrap())
        .collect();
    // Half of them have spoken (the dialect is known), half have not.
    for s in conns.iter_mut().step_by(2) {
        s.set_read_timeout(Some(Duration::from_secs(3))).unwrap();
        ask(s);
    }
    std::thread::sleep(Duration::from_millis(200));
    assert_eq!(emu.stats().connections, 50);
    let (t0, cpu0, sw0) = (Instant::now(), cpu_ticks(), context_switches());
    std::thread::sleep(Duration::from_secs(1));
    let (cpu1, sw1) = (cpu_ticks(), context_switches());
    let secs = t0.elapsed().as_secs_f64();
    let core_share = (cpu1 - cpu0) as f64 / USER_HZ / secs;
    let wakeups_per_conn_s = (sw1 - sw0) as f64 / secs / 50.0;
    println!(
        "50 idle connections: {:.1} % of a core, {wakeups_per_conn_s:.1} wake-ups per \
         connection per second",
        100.0 * core_share
    );
    assert!(core_share < 0.10, "{:.1} % of a core", 100.0 * core_share);
    // A loop polling every 2 ms wakes 500 times a second; one sleeping until something is
    // due, 10 times (its 100 ms wake for the stop flag).
    assert!(
        wakeups_per_conn_s < 50.0,
        "{wakeups_per_conn_s:.0} wake-ups per connection per second"
    );
    // Still served: idle, not closed.
    for s in conns.iter_mut().skip(1).step_by(2) {
        s.set_read_timeout(Some(Duration::from_secs(3))).unwrap();
        ask(s);
    }
    let st = emu.stop();
    assert_eq!((st.idle_closed, st.refused_connections), (0, 0), "{st:?}");
}
