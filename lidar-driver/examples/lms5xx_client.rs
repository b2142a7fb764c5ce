//! A minimal LMS5xx client over TCP with the session: connects, runs the start-up sequence,
//! prints every session event and one line per scan, for a bounded time.
//!
//! ```text
//! cargo run -p lms5xx-emulator -- --recording REC --port 2112 &
//! cargo run -p lidar-driver --example lms5xx_client -- 127.0.0.1:2112 10
//! ```

use std::time::{Duration, Instant};

use lidar_driver::clock::StdClock;
use lidar_driver::session::{Event, Session, SessionConfig};
use lidar_driver::transport::{TcpConfig, TcpLink};

fn main() {
    let mut args = std::env::args().skip(1);
    let addr = args.next().unwrap_or_else(|| "127.0.0.1:2112".into());
    let seconds: u64 = args.next().and_then(|s| s.parse().ok()).unwrap_or(10);
    let mut link = match TcpLink::new(addr.as_str(), TcpConfig::default()) {
        Ok(l) => l,
        Err(e) => {
            eprintln!("lms5xx_client: {addr}: {e}");
            std::process::exit(1);
        }
    };
    let mut session = Session::new(vec![0u8; 16 * 1024], SessionConfig::default());
    let clock = StdClock::new();
    let end = Instant::now() + Duration::from_secs(seconds);
    while Instant::now() < end {
        match session.poll(&mut link, &clock) {
            Event::Idle => {}
            Event::Scan(s) => {
                let d = s.dist1();
                let n = d.map_or(0, |c| c.len());
                let mid_m = d
                    .and_then(|c| c.ranges_m().nth(n / 2))
                    .flatten()
                    .unwrap_or(f32::NAN);
                println!(
                    "scan {:5}  {} points  straight ahead {:.3} m",
                    s.header.scan_counter, n, mid_m
                );
            }
            Event::Failed(e) => {
                eprintln!("gave up: {e}");
                std::process::exit(1);
            }
            other => eprintln!("{other}"),
        }
    }
    session.stop(&mut link);
    let st = session.stats();
    let fs = session.framer_stats();
    println!(
        "scans {} streams {} failures {} ignored {} bad frames {}",
        st.scans,
        st.streams_started,
        st.failures,
        st.ignored_frames,
        fs.frames_bad()
    );
}
