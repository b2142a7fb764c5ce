//! The emulator bounds what its clients cost: connections past the limit are closed at once
//! while the others are answered, a silent connection is closed after the idle time-out (a
//! streaming one is not), and a half-sent telegram is dropped after its time-out so the next
//! requests are answered.

mod session_support;

use std::io::{self, Read, Write};
use std::net::TcpStream;
use std::time::{Duration, Instant};

use lidar_driver::{Answer, CommandType, Dialect, Frame, Framer, Request, Telegram};
use lms5xx_emulator::{Emulator, EmulatorConfig, Limits};

use session_support::lms511_source;

/// Longest any answer or close may take, even on a loaded machine.
const PATIENCE: Duration = Duration::from_secs(3);

fn ms(n: u64) -> Duration {
    Duration::from_millis(n)
}

fn emulator(limits: Limits) -> Emulator {
    let config = EmulatorConfig {
        limits,
        ..EmulatorConfig::default()
    };
    Emulator::start(config, lms511_source()).unwrap()
}

fn request(r: Request<'_>) -> Vec<u8> {
    let mut b = [0u8; 256];
    let n = r.emit(Dialect::ColaB, &mut b).unwrap();
    b[..n].to_vec()
}

fn firmware_version() -> Vec<u8> {
    request(Request::Read("FirmwareVersion"))
}

/// A raw CoLa-B client.
struct Client {
    s: TcpStream,
    framer: Framer<Vec<u8>>,
    frames: Vec<Vec<u8>>,
}

impl Client {
    fn connect(emu: &Emulator) -> Self {
        let s = TcpStream::connect(emu.addr().unwrap()).unwrap();
        s.set_read_timeout(Some(ms(20))).unwrap();
        Client {
            s,
            framer: Framer::new(vec![0u8; 64 * 1024]),
            frames: Vec::new(),
        }
    }

    /// Reads until a frame that is not a scan or event arrives (`Some`), the emulator closes
    /// the connection (`None`), or [`PATIENCE`] passes (a panic).
    fn next_answer(&mut self) -> Option<Vec<u8>> {
        let end = Instant::now() + PATIENCE;
        let mut buf = [0u8; 8192];
        loop {
            while !self.frames.is_empty() {
                let f = self.frames.remove(0);
                let t = Telegram::parse(Frame::new_checked(&f).unwrap()).unwrap();
                if t.kind() != CommandType::Event {
                    return Some(f);
                }
            }
            assert!(Instant::now() < end, "no answer and not closed");
            match self.s.read(&mut buf) {
                Ok(0) => return None,
                Ok(n) => {
                    let frames = &mut self.frames;
                    self.framer
                        .feed(&buf[..n], |r| frames.push(r.unwrap().as_bytes().to_vec()));
                }
                Err(e) if timed_out(&e) => {}
                Err(_) => return None,
            }
        }
    }

    /// Sends `req` and returns the answer (`None`: the emulator closed the connection).
    fn ask(&mut self, req: &[u8]) -> Option<Vec<u8>> {
        if self.s.write_all(req).is_err() {
            return None;
        }
        self.next_answer()
    }

    /// Whether `sRN FirmwareVersion` gets the LMS511's answer.
    fn answers(&mut self) -> bool {
        self.ask(&firmware_version()).is_some_and(|a| {
            matches!(
                Answer::from_frame(Frame::new_checked(&a).unwrap()),
                Ok(Answer::FirmwareVersion(_))
            )
        })
    }

    /// Reads what has arrived, keeping answers and dropping scans and events.
    fn drain(&mut self) {
        let mut buf = [0u8; 8192];
        while let Ok(n @ 1..) = self.s.read(&mut buf) {
            let frames = &mut self.frames;
            self.framer
                .feed(&buf[..n], |r| frames.push(r.unwrap().as_bytes().to_vec()));
        }
        self.frames.retain(|f| {
            let t = Telegram::parse(Frame::new_checked(f).unwrap()).unwrap();
            t.kind() != CommandType::Event
        });
    }

    /// Waits for the emulator to close the connection. Panics on any frame other than scans
    /// and events, or after [`PATIENCE`].
    fn closed_within(&mut self) {
        assert_eq!(self.next_answer(), None, "expected the connection closed");
    }
}

fn timed_out(e: &io::Error) -> bool {
    matches!(
        e.kind(),
        io::ErrorKind::WouldBlock | io::ErrorKind::TimedOut
    )
}

#[test]
fn connections_past_the_limit_are_closed_while_the_others_are_answered() {
    let emu = emulator(Limits {
        max_connections: 3,
        ..Limits::default()
    });
    let mut served: Vec<Client> = (0..3).map(|_| Client::connect(&emu)).collect();
    for (i, c) in served.iter_mut().enumerate() {
        assert!(c.answers(), "connection {i} within the limit");
    }
    let mut extra: Vec<Client> = (0..2).map(|_| Client::connect(&emu)).collect();
    for c in &mut extra {
        c.closed_within();
    }
    for (i, c) in served.iter_mut().enumerate() {
        assert!(c.answers(), "connection {i} after the refusals");
    }
    // A connection that ends frees its place.
    drop(served.remove(0));
    let end = Instant::now() + PATIENCE;
    let mut again = loop {
        let mut c = Client::connect(&emu);
        if c.answers() {
            break c;
        }
        assert!(
            Instant::now() < end,
            "the freed place was not given to a new connection"
        );
        std::thread::sleep(ms(20));
    };
    assert!(again.answers());
    let st = emu.stop();
    // Refused: the two extra ones, and any retry that came before the place was freed.
    assert!(st.refused_connections >= 2, "{st:?}");
    assert_eq!(st.connections, 4, "{st:?}");
}

#[test]
fn a_silent_connection_is_closed_after_the_idle_time_out_a_streaming_one_is_not() {
    let idle = ms(300);
    let emu = emulator(Limits {
        idle_timeout: idle,
        ..Limits::default()
    });
    let mut streaming = Client::connect(&emu);
    let subscribe = request(Request::Subscribe {
        event: "LMDscandata",
        enable: true,
    });
    assert!(streaming.ask(&subscribe).is_some());
    // Requests more often than the time-out keep a connection open.
    let mut talking = Client::connect(&emu);
    for _ in 0..5 {
        assert!(talking.answers());
        std::thread::sleep(ms(120));
        streaming.drain();
    }
    drop(talking);
    let mut silent = Client::connect(&emu);
    // From before its last request, which the emulator heard after this instant.
    let t0 = Instant::now();
    assert!(silent.answers());
    silent.closed_within();
    let took = t0.elapsed();
    assert!(
        took >= idle,
        "closed {took:?} after the last request: before the time-out"
    );
    // The streaming client sent nothing for more than four times the time-out and still
    // gets scans and answers.
    for _ in 0..3 {
        std::thread::sleep(ms(100));
        streaming.drain();
    }
    assert!(streaming.answers());
    let st = emu.stop();
    assert_eq!(st.idle_closed, 1, "{st:?}");
    assert!(st.scans_sent > 5, "{st:?}");
}

#[test]
fn a_half_sent_telegram_is_dropped_after_its_time_out_and_the_next_requests_are_answered() {
    let timeout = ms(300);
    let emu = emulator(Limits {
        partial_frame_timeout: timeout,
        ..Limits::default()
    });
    let mut c = Client::connect(&emu);
    assert!(c.answers());
    // A CoLa-B header claiming 256 bytes, then 8 of them, then nothing.
    let mut half = vec![2, 2, 2, 2, 0, 0, 1, 0];
    half.extend_from_slice(b"sRN Firm");
    c.s.write_all(&half).unwrap();
    std::thread::sleep(timeout + ms(150));
    assert!(c.answers(), "request after the time-out");
    // Sent right behind the half telegram, a request is read as its payload at first, then
    // found again when the half telegram is dropped: answered after the time-out, not lost.
    let t0 = Instant::now();
    let mut both = half.clone();
    both.extend_from_slice(&firmware_version());
    c.s.write_all(&both).unwrap();
    assert!(
        c.next_answer().is_some(),
        "request behind the half telegram"
    );
    let took = t0.elapsed();
    assert!(
        took >= timeout,
        "answered {took:?} after sending: before the time-out"
    );
    assert!(c.answers());
    let st = emu.stop();
    assert_eq!(st.partial_frames_dropped, 2, "{st:?}");
    assert_eq!(st.idle_closed, 0, "{st:?}");
}
