//! [`CommandType`]: the three letters that open every SOPAS telegram (`sRN` … `sFA`). Its
//! own module because both the telegram view and the argument writer use it.

use core::fmt;

/// The SOPAS command types (first three payload bytes).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum CommandType {
    /// `sRN`: read a variable (host → sensor).
    ReadRequest,
    /// `sWN`: write a variable (host → sensor).
    WriteRequest,
    /// `sMN`: call a method (host → sensor).
    MethodRequest,
    /// `sEN`: subscribe to / unsubscribe from an event (host → sensor).
    EventRequest,
    /// `sRA`: read answer (sensor → host).
    ReadAnswer,
    /// `sWA`: write acknowledged (sensor → host).
    WriteAnswer,
    /// `sAN`: method answer (sensor → host).
    MethodAnswer,
    /// `sMA`: method accepted, the `sAN` follows later (sensor → host).
    MethodAccepted,
    /// `sEA`: event subscription answer (sensor → host).
    EventAnswer,
    /// `sSN`: event data, e.g. a streamed scan (sensor → host).
    Event,
    /// `sFA`: error answer with a code (sensor → host).
    Error,
}

impl CommandType {
    /// All command types, requests first.
    pub const ALL: [CommandType; 11] = [
        CommandType::ReadRequest,
        CommandType::WriteRequest,
        CommandType::MethodRequest,
        CommandType::EventRequest,
        CommandType::ReadAnswer,
        CommandType::WriteAnswer,
        CommandType::MethodAnswer,
        CommandType::MethodAccepted,
        CommandType::EventAnswer,
        CommandType::Event,
        CommandType::Error,
    ];

    /// The three ASCII letters on the wire.
    pub fn as_str(self) -> &'static str {
        match self {
            CommandType::ReadRequest => "sRN",
            CommandType::WriteRequest => "sWN",
            CommandType::MethodRequest => "sMN",
            CommandType::EventRequest => "sEN",
            CommandType::ReadAnswer => "sRA",
            CommandType::WriteAnswer => "sWA",
            CommandType::MethodAnswer => "sAN",
            CommandType::MethodAccepted => "sMA",
            CommandType::EventAnswer => "sEA",
            CommandType::Event => "sSN",
            CommandType::Error => "sFA",
        }
    }

    /// Parses the three letters.
    pub fn from_bytes(b: &[u8]) -> Option<Self> {
        Self::ALL.into_iter().find(|c| c.as_str().as_bytes() == b)
    }

    /// True for the host's requests (`sRN sWN sMN sEN`), false for the sensor's answers. This is
    /// how records without a direction (SICK's `.pcapng.json`, raw streams) are classified.
    pub fn is_request(self) -> bool {
        matches!(
            self,
            CommandType::ReadRequest
                | CommandType::WriteRequest
                | CommandType::MethodRequest
                | CommandType::EventRequest
        )
    }
}

impl fmt::Display for CommandType {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}
