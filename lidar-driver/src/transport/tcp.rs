//! TCP link to the sensor (port 2112 by default), with connect, read-ready and write time-outs
//! and re-connect.

use std::io::{self, Write as _};
use std::net::{Shutdown, SocketAddr, TcpStream, ToSocketAddrs};
use std::time::Duration;

use super::read_ahead::{connected, read_through_ahead, ReadAhead};
use super::Transport;

/// The TCP port SICK's driver uses for both dialects (2111 also serves CoLa-A).
pub const SICK_TCP_PORT: u16 = 2112;

/// Time limits of a [`TcpLink`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TcpConfig {
    /// Longest wait for a connection to be accepted, per address.
    pub connect_timeout: Duration,
    /// Longest wait of `read_ready` for the first bytes (keeps poll loops from spinning).
    pub ready_wait: Duration,
    /// Longest a write may block (sensor not reading).
    pub write_timeout: Duration,
    /// Receive buffer, bytes.
    pub read_ahead_len: usize,
}

impl Default for TcpConfig {
    fn default() -> Self {
        TcpConfig {
            connect_timeout: Duration::from_secs(2),
            ready_wait: Duration::from_millis(5),
            write_timeout: Duration::from_secs(2),
            read_ahead_len: 16 * 1024,
        }
    }
}

/// A TCP connection to a scanner that can be re-opened. Created closed: the session (or the
/// caller) opens it with [`Transport::reconnect`].
///
/// Errors are [`std::io::Error`]; a read with no data yet fails with kind `TimedOut`.
#[derive(Debug)]
pub struct TcpLink {
    addrs: Vec<SocketAddr>,
    config: TcpConfig,
    stream: Option<TcpStream>,
    ahead: ReadAhead,
}

impl TcpLink {
    /// A closed link to `addr` (e.g. `"192.168.0.1:2112"`), resolved now.
    pub fn new(addr: impl ToSocketAddrs, config: TcpConfig) -> io::Result<Self> {
        let addrs: Vec<SocketAddr> = addr.to_socket_addrs()?.collect();
        if addrs.is_empty() {
            return Err(io::Error::new(
                io::ErrorKind::InvalidInput,
                "sensor address resolved to nothing",
            ));
        }
        Ok(TcpLink {
            addrs,
            config,
            stream: None,
            ahead: ReadAhead::new(config.read_ahead_len),
        })
    }

    /// A link to `ip` on port 2112 with default time-outs.
    pub fn sick(ip: std::net::IpAddr) -> Self {
        let config = TcpConfig::default();
        TcpLink {
            addrs: vec![SocketAddr::new(ip, SICK_TCP_PORT)],
            config,
            stream: None,
            ahead: ReadAhead::new(config.read_ahead_len),
        }
    }

    /// True while a connection is open.
    pub fn is_connected(&self) -> bool {
        self.stream.is_some()
    }

    /// The addresses tried, in order.
    pub fn addrs(&self) -> &[SocketAddr] {
        &self.addrs
    }

    fn open(&self) -> io::Result<TcpStream> {
        let mut last = io::Error::new(io::ErrorKind::NotFound, "no address to connect to");
        for a in &self.addrs {
            match TcpStream::connect_timeout(a, self.config.connect_timeout) {
                Ok(s) => {
                    s.set_nodelay(true)?;
                    s.set_read_timeout(Some(nonzero(self.config.ready_wait)))?;
                    s.set_write_timeout(Some(nonzero(self.config.write_timeout)))?;
                    return Ok(s);
                }
                Err(e) => last = e,
            }
        }
        Err(last)
    }

    fn stream(&mut self) -> io::Result<&mut TcpStream> {
        connected(&mut self.stream)
    }
}

/// Socket time-outs of zero mean "forever" to std: never pass one.
fn nonzero(d: Duration) -> Duration {
    d.max(Duration::from_millis(1))
}

read_through_ahead!(TcpLink, stream);

impl embedded_io::Write for TcpLink {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        self.stream()?.write(buf)
    }

    fn flush(&mut self) -> io::Result<()> {
        self.stream()?.flush()
    }
}

impl Transport for TcpLink {
    fn reconnect(&mut self) -> io::Result<()> {
        self.close();
        let s = self.open()?;
        self.stream = Some(s);
        Ok(())
    }

    fn close(&mut self) {
        if let Some(s) = self.stream.take() {
            let _ = s.shutdown(Shutdown::Both);
        }
        self.ahead.clear();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use embedded_io::{Read, ReadReady, Write};
    use std::io::Read as _;
    use std::net::TcpListener;

    #[test]
    fn connect_exchange_eof_and_reconnect() {
        let l = TcpListener::bind("127.0.0.1:0").unwrap();
        let addr = l.local_addr().unwrap();
        let mut link = TcpLink::new(addr, TcpConfig::default()).unwrap();
        assert_eq!(
            link.write(b"x").unwrap_err().kind(),
            io::ErrorKind::NotConnected
        );
        link.reconnect().unwrap();
        let (mut peer, _) = l.accept().unwrap();
        assert!(!link.read_ready().unwrap(), "no data yet, bounded wait");
        link.write_all(b"ping").unwrap();
        let mut got = [0u8; 4];
        peer.read_exact(&mut got).unwrap();
        assert_eq!(&got, b"ping");
        std::io::Write::write_all(&mut peer, b"pong").unwrap();
        drop(peer);
        let mut buf = [0u8; 16];
        let mut all = Vec::new();
        for _ in 0..200 {
            if link.read_ready().unwrap() {
                let n = link.read(&mut buf).unwrap();
                if n == 0 {
                    break;
                }
                all.extend_from_slice(&buf[..n]);
            }
        }
        assert_eq!(all, b"pong");
        link.reconnect().unwrap();
        assert!(link.is_connected());
        link.close();
        assert!(!link.is_connected());
    }

    #[test]
    fn refused_connection_is_an_error() {
        let port = {
            let l = TcpListener::bind("127.0.0.1:0").unwrap();
            l.local_addr().unwrap().port()
        };
        let mut link = TcpLink::new(("127.0.0.1", port), TcpConfig::default()).unwrap();
        let e = link.reconnect().unwrap_err();
        assert_eq!(e.kind(), io::ErrorKind::ConnectionRefused);
    }
}
