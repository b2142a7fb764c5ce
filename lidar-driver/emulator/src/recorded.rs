//! What a recorded sensor answered beyond the start-up steps the emulator models itself: the
//! answer to every other request (the field definitions `field000` … `field029`,
//! `LIDinputstate`, the `LFErec` / `LIDoutputstate` / `LIDinputstate` subscriptions, …) and
//! the events (`sSN`) it sent after a subscription, with their timing. The emulator replays
//! them as recorded, so a client that asks what the LMS511 of the capture was asked gets
//! what it got.
//!
//! The pairs come from the sensor's frames alone (an `sRA X` answers `sRN X`, `sEA X`
//! answers `sEN X`, `sAN X` answers `sMN X`, `sWA X` answers `sWN X`), so a raw
//! sensor-to-host stream is enough; `sFA` answers carry no name and are not replayed (the
//! emulator refuses by its own rules).
//!
//! **Dialects.** A recorded answer goes out byte for byte in its own dialect. Asked in the
//! other one, a CoLa-B answer is re-encoded for CoLa-A with one token per argument byte: the
//! binary layouts of these structures are not documented (SICK's own driver does not parse
//! them in CoLa-A either), so the values are kept byte by byte rather than guessed into
//! wider fields. A CoLa-A answer asked in CoLa-B is not replayed.

use std::time::Duration;

use lidar_driver::frame::Dialect;
use lidar_driver::recording::{Direction, Recording};
use lidar_driver::request::names;
use lidar_driver::telegram::{CommandType, Telegram};

/// One recorded answer (or event) frame.
#[derive(Debug, Clone, PartialEq)]
pub struct RecordedTelegram {
    /// The dialect it was recorded in.
    pub dialect: Dialect,
    /// The whole frame as recorded.
    pub frame: Vec<u8>,
}

/// A recorded event of a subscription, with when it came.
#[derive(Debug, Clone, PartialEq)]
pub struct RecordedEvent {
    /// Event name (`LIDoutputstate`, `LFErec`, …).
    pub name: String,
    /// Time after the subscription was acknowledged (or after the first event of the
    /// recording when the acknowledgement is not in it).
    pub after: Duration,
    /// The `sSN` frame.
    pub telegram: RecordedTelegram,
}

/// Everything a recording's sensor answered that the emulator replays as recorded.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct RecordedAnswers {
    /// `((request type, name), answer)`, the first answer per request.
    answers: Vec<((CommandType, String), RecordedTelegram)>,
    /// Events in recorded order.
    events: Vec<RecordedEvent>,
}

/// The non-scan records of the LMS511 capture (`lms511_20210302_colab.pcapng.json`: its
/// start-up dialogue, answers and events, every `sSN LMDscandata` left out), in SICK's
/// `.pcapng.json` format.
const LMS511_START_UP: &[u8] = include_bytes!("../data/lms511_start_up.pcapng.json");

/// The request type an answer type answers.
fn request_of(answer: CommandType) -> Option<CommandType> {
    Some(match answer {
        CommandType::ReadAnswer => CommandType::ReadRequest,
        CommandType::WriteAnswer => CommandType::WriteRequest,
        CommandType::MethodAnswer | CommandType::MethodAccepted => CommandType::MethodRequest,
        CommandType::EventAnswer => CommandType::EventRequest,
        _ => return None,
    })
}

impl RecordedAnswers {
    /// What the LMS511 of the capture answered and sent.
    pub fn lms511_capture() -> Self {
        Recording::parse(LMS511_START_UP)
            .map(|r| Self::from_recording(&r))
            .unwrap_or_default()
    }

    /// The answers and events of a recording's sensor.
    pub fn from_recording(rec: &Recording) -> Self {
        let mut out = Self::default();
        let mut acked: Vec<(String, f64)> = Vec::new();
        let mut first_event_s = None;
        for f in rec.frames().frames {
            if f.direction == Direction::HostToSensor {
                continue;
            }
            let Ok(t) = Telegram::parse(f.frame()) else {
                continue;
            };
            let name = t.name();
            if name == names::SCAN_DATA && t.kind() != CommandType::EventAnswer {
                continue;
            }
            let telegram = RecordedTelegram {
                dialect: f.dialect,
                frame: f.bytes.clone(),
            };
            let time_s = f.time_s.unwrap_or(0.0);
            if t.kind() == CommandType::Event {
                let since = acked
                    .iter()
                    .find(|(n, _)| n == name)
                    .map(|&(_, s)| s)
                    .unwrap_or(*first_event_s.get_or_insert(time_s));
                out.events.push(RecordedEvent {
                    name: name.to_string(),
                    after: Duration::from_secs_f64((time_s - since).max(0.0)),
                    telegram,
                });
                continue;
            }
            let Some(request) = request_of(t.kind()) else {
                continue;
            };
            if t.kind() == CommandType::EventAnswer {
                acked.push((name.to_string(), time_s));
            }
            let key = (request, name.to_string());
            if !out.answers.iter().any(|(k, _)| *k == key) {
                out.answers.push((key, telegram));
            }
        }
        out
    }

    /// The recorded answer to a request of `kind` for `name`.
    pub fn answer(&self, kind: CommandType, name: &str) -> Option<&RecordedTelegram> {
        self.answers
            .iter()
            .find(|((k, n), _)| *k == kind && n == name)
            .map(|(_, t)| t)
    }

    /// The recorded events of subscription `name`, in order.
    pub fn events<'s>(&'s self, name: &'s str) -> impl Iterator<Item = &'s RecordedEvent> + 's {
        self.events.iter().filter(move |e| e.name == name)
    }

    /// Whether the recording knows the event `name` (acknowledged a subscription, or sent it).
    pub fn knows_event(&self, name: &str) -> bool {
        self.answer(CommandType::EventRequest, name).is_some() || self.events(name).next().is_some()
    }

    /// Requests answered (type, name), in recorded order.
    pub fn requests(&self) -> impl Iterator<Item = (CommandType, &str)> {
        self.answers.iter().map(|((k, n), _)| (*k, n.as_str()))
    }
}

impl RecordedTelegram {
    /// The frame for a client speaking `dialect`: as recorded in its own dialect; a CoLa-B
    /// frame re-encoded for CoLa-A with one token per argument byte; `None` for a CoLa-A
    /// frame asked in CoLa-B.
    pub fn for_dialect(&self, dialect: Dialect) -> Option<Vec<u8>> {
        if dialect == self.dialect {
            return Some(self.frame.clone());
        }
        if dialect == Dialect::ColaB {
            return None;
        }
        let f = lidar_driver::Frame::new_checked(&self.frame).ok()?;
        let t = Telegram::parse(f).ok()?;
        let mut out = vec![0x02];
        out.extend_from_slice(t.kind().as_str().as_bytes());
        out.push(b' ');
        out.extend_from_slice(t.name().as_bytes());
        for b in t.args() {
            out.extend_from_slice(format!(" {b:X}").as_bytes());
        }
        out.push(0x03);
        Some(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_capture_answers_fields_input_states_and_subscriptions() {
        let r = RecordedAnswers::lms511_capture();
        for n in 0..30 {
            let name = format!("field{n:03}");
            assert!(
                r.answer(CommandType::ReadRequest, &name).is_some(),
                "{name}"
            );
        }
        assert!(r
            .answer(CommandType::ReadRequest, "LIDinputstate")
            .is_some());
        for e in ["LFErec", "LIDoutputstate", "LIDinputstate"] {
            assert!(r.answer(CommandType::EventRequest, e).is_some(), "{e}");
            assert!(r.knows_event(e));
        }
        let out: Vec<_> = r.events("LIDoutputstate").map(|e| e.after).collect();
        assert_eq!(out.len(), 4);
        assert!(
            out[0] < Duration::from_millis(10) && out[3] > Duration::from_secs(1),
            "{out:?}"
        );
        assert_eq!(r.events("LFErec").count(), 1);
        // CoLa-A: one token per argument byte.
        let f = r.answer(CommandType::ReadRequest, "field010").unwrap();
        assert_eq!(
            f.for_dialect(Dialect::ColaA).unwrap(),
            b"\x02sRA field010 0\x03"
        );
        assert_eq!(f.for_dialect(Dialect::ColaB).unwrap(), f.frame);
    }
}
