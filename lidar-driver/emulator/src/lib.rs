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
//! Resources are bounded ([`Limits`]): at most `max_connections` TCP connections are served
//! (one more is closed at once), a connection silent for `idle_timeout` while not streaming
//! is closed, and a telegram left half-sent for `partial_frame_timeout` is dropped so the
//! next requests are answered. A connection's thread sleeps in its read until a byte comes or
//! something is due (a scan, a recorded event, a time-out; at most 100 ms), so idle
//! connections cost no CPU to speak of; the accept thread polls every 10 ms.
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
mod receive;
mod recorded;
mod source;
mod stats;

pub use config::{DeviceIdentity, DialectMode, EmulatorConfig, Faults, Limits};
pub use recorded::{RecordedAnswers, RecordedEvent, RecordedTelegram};
pub use source::{RecordingSource, ScanSource, SourceError};
pub use stats::EmulatorStats;

use std::io::{self, Read, Write};
use std::net::{Ipv4Addr, SocketAddr, TcpListener, TcpStream};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use lidar_driver::ScanRepr;

use device::{Connection, Settings, Verdict};
use receive::Receiver;
use stats::StatsCell;

/// Longest a TCP connection's read waits when nothing is due: the loop then looks at the
/// stop flag (a stop also shuts the sockets down, which ends the reads at once).
const IDLE_WAKE: Duration = Duration::from_millis(100);
/// Shortest read wait: a deadline just passed is handled after a 1 ms read.
const MIN_WAIT: Duration = Duration::from_millis(1);
/// How often the accept thread looks for new connections (and the stop flag).
const ACCEPT_POLL: Duration = Duration::from_millis(10);
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
    /// its own thread, up to [`Limits::max_connections`] at once.
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
    /// loop can send scans and notice [`Emulator::stop`]. The stream is never closed for
    /// being idle (a serial line has no connection to open again); half-sent telegrams time
    /// out as on TCP.
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
                let _ = serve(&s, &mut FixedWait(&mut stream));
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

/// A connection being served: its thread, and a handle on its socket to end it on stop.
struct Served {
    thread: JoinHandle<()>,
    socket: Option<TcpStream>,
}

fn accept_loop(shared: &Arc<Shared>, listener: &TcpListener) {
    let mut conns: Vec<Served> = Vec::new();
    while !shared.stopping() {
        match listener.accept() {
            // Take the whole backlog before sleeping again.
            Ok((stream, _)) => admit(shared, stream, &mut conns),
            // Nothing waiting, or an error such as too many open files: wait, never spin.
            Err(_) => std::thread::sleep(ACCEPT_POLL),
        }
    }
    // Reads blocked on a socket end when it is shut down: the threads stop at once.
    for c in &conns {
        if let Some(s) = &c.socket {
            let _ = s.shutdown(std::net::Shutdown::Both);
        }
    }
    for c in conns {
        let _ = c.thread.join();
    }
}

/// Serves `stream` on a thread of its own, or closes it at once when
/// [`Limits::max_connections`] are served already (or no thread can be had).
fn admit(shared: &Arc<Shared>, stream: TcpStream, conns: &mut Vec<Served>) {
    conns.retain(|c| !c.thread.is_finished());
    if conns.len() >= shared.config.limits.max_connections {
        refuse(shared, &stream);
        return;
    }
    let socket = stream.try_clone().ok();
    let s = Arc::clone(shared);
    let spawned = std::thread::Builder::new()
        .name("lms5xx-emulator-conn".into())
        .spawn(move || {
            let _ = serve_tcp(&s, stream);
        });
    match spawned {
        Ok(thread) => {
            shared.stats.count(|c| c.connections += 1);
            conns.push(Served { thread, socket });
        }
        // The stream went with the closure that was not run: it is closed.
        Err(_) => shared.stats.count(|c| c.refused_connections += 1),
    }
}

/// Closes a connection that is not served.
fn refuse(shared: &Shared, stream: &TcpStream) {
    let _ = stream.shutdown(std::net::Shutdown::Both);
    shared.stats.count(|c| c.refused_connections += 1);
}

fn serve_tcp(shared: &Shared, mut stream: TcpStream) -> io::Result<()> {
    stream.set_nonblocking(false)?;
    stream.set_nodelay(true)?;
    stream.set_read_timeout(Some(IDLE_WAKE))?;
    stream.set_write_timeout(Some(Duration::from_secs(2)))?;
    let r = serve(shared, &mut stream);
    let _ = stream.shutdown(std::net::Shutdown::Both);
    r
}

/// A byte stream the connection loop serves.
trait Link: Read + Write {
    /// Whether the link is a connection closed after [`Limits::idle_timeout`].
    const CLOSED_WHEN_IDLE: bool;

    /// Lets the next read wait up to `wait` for a byte.
    fn wait_at_most(&mut self, wait: Duration) -> io::Result<()>;
}

impl Link for TcpStream {
    const CLOSED_WHEN_IDLE: bool = true;

    fn wait_at_most(&mut self, wait: Duration) -> io::Result<()> {
        self.set_read_timeout(Some(wait.max(MIN_WAIT)))
    }
}

/// A stream whose reads time out by themselves after a few milliseconds (a serial port).
struct FixedWait<S>(S);

impl<S: Read> Read for FixedWait<S> {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        self.0.read(buf)
    }
}

impl<S: Write> Write for FixedWait<S> {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        self.0.write(buf)
    }

    fn flush(&mut self) -> io::Result<()> {
        self.0.flush()
    }
}

impl<S: Read + Write> Link for FixedWait<S> {
    const CLOSED_WHEN_IDLE: bool = false;

    fn wait_at_most(&mut self, _wait: Duration) -> io::Result<()> {
        Ok(())
    }
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

/// The connection loop: read (until a byte comes or something is due), answer, send scans
/// due, until the peer closes, a fault drops the connection, it stays idle too long, or the
/// emulator stops.
fn serve<L: Link>(shared: &Shared, link: &mut L) -> io::Result<()> {
    let limits = shared.config.limits;
    let mut rx = Receiver::new(RX_BUFFER_LEN, limits.partial_frame_timeout);
    let mut conn = Connection::new(shared);
    let mut buf = vec![0u8; 4096];
    let mut out = Vec::with_capacity(16 * 1024);
    let mut last_heard = Instant::now();
    while !shared.stopping() {
        match link.read(&mut buf) {
            Ok(0) => return Ok(()),
            Ok(n) => {
                let now = Instant::now();
                last_heard = now;
                rx.feed(&buf[..n], now, |frame| conn.on_frame(frame, now, &mut out));
            }
            Err(e) if is_no_data(&e) => {}
            Err(e) => return Err(e),
        }
        let now = Instant::now();
        let dropped = rx.expire(now, |frame| conn.on_frame(frame, now, &mut out));
        if dropped > 0 {
            shared.stats.count(|c| c.partial_frames_dropped += dropped);
        }
        let verdict = conn.tick(now, &mut out);
        if !out.is_empty() {
            write_patiently(shared, link, &out)?;
            out.clear();
        }
        if verdict == Verdict::Drop {
            return Ok(());
        }
        let idle_end =
            (L::CLOSED_WHEN_IDLE && !conn.streaming()).then(|| last_heard + limits.idle_timeout);
        if idle_end.is_some_and(|end| now >= end) {
            shared.stats.count(|c| c.idle_closed += 1);
            return Ok(());
        }
        let next = [conn.next_due(now), rx.deadline(), idle_end]
            .into_iter()
            .flatten()
            .min();
        let wait = next.map_or(IDLE_WAKE, |t| t.saturating_duration_since(now));
        link.wait_at_most(wait.clamp(MIN_WAIT, IDLE_WAKE))?;
    }
    Ok(())
}
