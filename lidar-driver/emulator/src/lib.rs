//! LMS5xx emulator (feature `std`): a TCP server on 127.0.0.1 (or any byte stream, e.g. a
//! serial pty) that answers the start-up sequence in both dialects like the LMS511 of the
//! capture, reports busy for a start-up delay, streams scans at the configured rate after
//! `sEN LMDscandata 1`, and injects faults on request.
//!
//! Scans come from a [`ScanSource`]: a recording replayed in a loop ([`RecordingSource`]) or
//! the caller's closure / type (the simulator's ray caster). With `restamp` (default) the
//! emulator writes counters, timestamps and frequency like a live device; the channels are
//! shaped by the client's `LMDscandatacfg` (echo mask, RSSI on/off, time block).
//!
//! Connections share the one source (two subscribed clients take turns on its scans) and the
//! device settings (output range, `LMDscandatacfg`, scan configuration persist across
//! connections, as on the device until power-off).
//!
//! Per connection the dialect is taken from the first frame ([`DialectMode::Auto`]) or fixed.
//! Unknown names get `sFA` 2/3; changes without `SetAccessMode` level 3 get `sFA` 1 / 10;
//! during the start-up delay everything but `SCdevicestate` gets `sFA 13` (busy).
//!
//! ```no_run
//! use lms5xx_emulator::{Emulator, EmulatorConfig, RecordingSource};
//! let source = RecordingSource::from_file("lms511_20210302_colab.pcapng.json").unwrap();
//! let emu = Emulator::start(EmulatorConfig::default(), source).unwrap();
//! println!("listening on {}", emu.addr().unwrap());
//! // … run a client; the emulator stops when dropped.
//! ```

mod config;
mod device;
mod recorded;
mod source;
mod stats;

pub use config::{DeviceIdentity, DialectMode, EmulatorConfig, Faults};
pub use recorded::{RecordedAnswers, RecordedEvent, RecordedTelegram};
pub use source::{RecordingSource, ScanSource, SourceError};
pub use stats::EmulatorStats;

use std::io::{self, Read, Write};
use std::net::{Ipv4Addr, SocketAddr, TcpListener, TcpStream};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use lidar_driver::framer::Framer;
use lidar_driver::ScanRepr;

use device::{Connection, Settings, Verdict};
use stats::StatsCell;

/// How long one read of a connection waits before the loop checks scans due and the stop flag.
const READ_WAIT: Duration = Duration::from_millis(2);
/// Receive buffer per connection: a CoLa-A scan-sized request would fit; requests are tiny.
const RX_BUFFER_LEN: usize = 16 * 1024;

/// State shared by the accept thread and the connections.
pub(crate) struct Shared {
    pub(crate) config: EmulatorConfig,
    /// Power-up time.
    pub(crate) started: Instant,
    source: Mutex<Box<dyn ScanSource>>,
    settings: Mutex<Settings>,
    pub(crate) stats: StatsCell,
    stop: AtomicBool,
}

impl Shared {
    fn new(config: EmulatorConfig, source: Box<dyn ScanSource>) -> Self {
        Shared {
            settings: Mutex::new(Settings::new(&config)),
            config,
            started: Instant::now(),
            source: Mutex::new(source),
            stats: StatsCell::default(),
            stop: AtomicBool::new(false),
        }
    }

    /// The device settings (a poisoned lock is recovered: the data stay consistent).
    pub(crate) fn settings(&self) -> MutexGuard<'_, Settings> {
        self.settings.lock().unwrap_or_else(|p| p.into_inner())
    }

    pub(crate) fn next_scan(&self) -> Option<ScanRepr> {
        self.source
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .next_scan()
    }

    fn stopping(&self) -> bool {
        self.stop.load(Ordering::Relaxed)
    }
}

/// A running emulator; stops (threads joined) on [`Emulator::stop`] or drop.
pub struct Emulator {
    shared: Arc<Shared>,
    addr: Option<SocketAddr>,
    thread: Option<JoinHandle<()>>,
}

impl core::fmt::Debug for Emulator {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("Emulator")
            .field("addr", &self.addr)
            .field("stats", &self.stats())
            .finish()
    }
}

impl Emulator {
    /// Listens on `127.0.0.1:config.port` (0 = a free port) and serves every connection on
    /// its own thread.
    pub fn start(config: EmulatorConfig, source: impl ScanSource + 'static) -> io::Result<Self> {
        let listener = TcpListener::bind((Ipv4Addr::LOCALHOST, config.port))?;
        listener.set_nonblocking(true)?;
        let addr = listener.local_addr()?;
        let shared = Arc::new(Shared::new(config, Box::new(source)));
        let s = Arc::clone(&shared);
        let thread = std::thread::Builder::new()
            .name("lms5xx-emulator".into())
            .spawn(move || accept_loop(&s, &listener))?;
        Ok(Emulator {
            shared,
            addr: Some(addr),
            thread: Some(thread),
        })
    }

    /// Serves one byte stream (a serial port, a pty, a pipe) on a thread. The stream's reads
    /// must time out after a few milliseconds (e.g. `serialport` with `.timeout(2 ms)`), so the
    /// loop can send scans and notice [`Emulator::stop`].
    pub fn start_on_stream<S>(
        config: EmulatorConfig,
        source: impl ScanSource + 'static,
        stream: S,
    ) -> io::Result<Self>
    where
        S: Read + Write + Send + 'static,
    {
        let shared = Arc::new(Shared::new(config, Box::new(source)));
        let s = Arc::clone(&shared);
        let thread = std::thread::Builder::new()
            .name("lms5xx-emulator-stream".into())
            .spawn(move || {
                let mut stream = stream;
                s.stats.count(|c| c.connections += 1);
                let _ = serve(&s, &mut stream);
            })?;
        Ok(Emulator {
            shared,
            addr: None,
            thread: Some(thread),
        })
    }

    /// The TCP address (`None` for [`Emulator::start_on_stream`]).
    pub fn addr(&self) -> Option<SocketAddr> {
        self.addr
    }

    /// Counters so far.
    pub fn stats(&self) -> EmulatorStats {
        self.shared.stats.snapshot()
    }

    /// Stops accepting, closes all connections and joins the threads (within a few ms).
    pub fn stop(mut self) -> EmulatorStats {
        self.halt();
        self.stats()
    }

    fn halt(&mut self) {
        self.shared.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

impl Drop for Emulator {
    fn drop(&mut self) {
        self.halt();
    }
}

fn accept_loop(shared: &Arc<Shared>, listener: &TcpListener) {
    let mut conns: Vec<JoinHandle<()>> = Vec::new();
    while !shared.stopping() {
        match listener.accept() {
            Ok((stream, _)) => {
                shared.stats.count(|c| c.connections += 1);
                let s = Arc::clone(shared);
                let spawned = std::thread::Builder::new()
                    .name("lms5xx-emulator-conn".into())
                    .spawn(move || {
                        let _ = serve_tcp(&s, stream);
                    });
                if let Ok(h) = spawned {
                    conns.push(h);
                }
            }
            Err(e) if e.kind() == io::ErrorKind::WouldBlock => {
                std::thread::sleep(Duration::from_millis(5));
            }
            Err(_) => std::thread::sleep(Duration::from_millis(5)),
        }
        conns.retain(|h| !h.is_finished());
    }
    for h in conns {
        let _ = h.join();
    }
}

fn serve_tcp(shared: &Shared, mut stream: TcpStream) -> io::Result<()> {
    stream.set_nonblocking(false)?;
    stream.set_nodelay(true)?;
    stream.set_read_timeout(Some(READ_WAIT))?;
    stream.set_write_timeout(Some(Duration::from_secs(2)))?;
    let r = serve(shared, &mut stream);
    let _ = stream.shutdown(std::net::Shutdown::Both);
    r
}

/// Longest the emulator waits for a client to take its bytes before it gives the client up.
const WRITE_PATIENCE: Duration = Duration::from_secs(2);

/// `write_all` that rides out short write time-outs (a serial port's time-out is also its
/// read time-out, a few ms; a pty buffer holds less than one CoLa-A scan), up to
/// [`WRITE_PATIENCE`] or a stop.
fn write_patiently<S: Write>(shared: &Shared, stream: &mut S, mut bytes: &[u8]) -> io::Result<()> {
    let deadline = Instant::now() + WRITE_PATIENCE;
    while !bytes.is_empty() {
        match stream.write(bytes) {
            Ok(0) => return Err(io::ErrorKind::WriteZero.into()),
            Ok(n) => bytes = &bytes[n..],
            Err(e) if is_no_data(&e) && Instant::now() < deadline && !shared.stopping() => {}
            Err(e) => return Err(e),
        }
    }
    loop {
        match stream.flush() {
            Err(e) if is_no_data(&e) && Instant::now() < deadline => {}
            r => return r,
        }
    }
}

fn is_no_data(e: &io::Error) -> bool {
    matches!(
        e.kind(),
        io::ErrorKind::WouldBlock | io::ErrorKind::TimedOut | io::ErrorKind::Interrupted
    )
}

/// The connection loop: read (short time-out), answer, send scans due, until the peer closes,
/// a fault drops the connection, or the emulator stops.
fn serve<S: Read + Write>(shared: &Shared, stream: &mut S) -> io::Result<()> {
    let mut framer = Framer::new(vec![0u8; RX_BUFFER_LEN]);
    let mut conn = Connection::new(shared);
    let mut buf = vec![0u8; 4096];
    let mut out = Vec::with_capacity(16 * 1024);
    while !shared.stopping() {
        match stream.read(&mut buf) {
            Ok(0) => return Ok(()),
            Ok(n) => {
                let now = Instant::now();
                framer.feed(&buf[..n], |r| {
                    if let Ok(frame) = r {
                        conn.on_frame(frame, now, &mut out);
                    }
                });
            }
            Err(e) if is_no_data(&e) => {}
            Err(e) => return Err(e),
        }
        let verdict = conn.tick(Instant::now(), &mut out);
        if !out.is_empty() {
            write_patiently(shared, stream, &out)?;
            out.clear();
        }
        if verdict == Verdict::Drop {
            return Ok(());
        }
    }
    Ok(())
}
