//! The vehicle's side of the controller's vehicle port (UART1 under QEMU, a TCP socket
//! here): the odometry frame for each scan out, the controller's pose frame back, in lock
//! step with the emulated scanner.

use std::io::{self, Read, Write};
use std::net::{Ipv4Addr, TcpListener, TcpStream};
use std::path::Path;
use std::sync::mpsc::Sender;
use std::time::{Duration, Instant};

use controller_wire::{
    Assembled, FrameAssembler, OdometryFrame, PoseFrame, PoseStatus, MAX_FRAME_BYTES,
    MAX_ODOMETRY_FRAME_BYTES,
};

use crate::odometry_gaps::GapTracker;
use crate::record::csv_table::CsvTable;
use crate::record::{files, odometry_csv};
use crate::vehicle::SimPose;

/// Why the lock step stopped.
#[derive(Debug)]
pub enum PortError {
    /// No pose frame for this scan within the time-out.
    NoPose {
        /// The scan.
        scan: usize,
    },
    /// The socket failed.
    Io(io::Error),
}

/// The scans' times in a recording (`scanner.colab.times.csv`), seconds.
pub fn scan_times(recording: &Path) -> Result<Vec<f64>, String> {
    let t = CsvTable::read_columns(&recording.join(files::SCANNER_TIMES), &["t_s"])
        .map_err(|e| e.to_string())?;
    let c = t.column("t_s").map_err(|e| e.to_string())?;
    Ok(t.rows().iter().map(|r| r[c]).collect())
}

/// The odometry frame the vehicle sends when the run starts, before any scan: its
/// cumulative odometry pose where the recording's initial pose holds (the origin, at the
/// time of the first reading's start). The controller takes the first frame it receives
/// as the reading at its start pose, and predicts its first scan from there.
pub fn start_frame() -> OdometryFrame {
    OdometryFrame {
        sequence: 0,
        time_us: 0,
        x_m: 0.0,
        y_m: 0.0,
        theta_rad: 0.0,
    }
}

/// The odometry frame the vehicle sends before each scan of `recording` (at `times`, its
/// [`scan_times`]): its cumulative odometry pose at the scan's time — every reading up to
/// it, then on at the last reading's rate up to the scan, shared out between readings and
/// scans as `replay` does ([`GapTracker`]), so that the controller predicts each scan as the
/// replay does (sequence numbers from 1: the [`start_frame`] is 0).
pub fn odometry_frames(recording: &Path, times: &[f64]) -> Result<Vec<OdometryFrame>, String> {
    let log = odometry_csv::read(&recording.join(files::ODOMETRY)).map_err(|e| e.to_string())?;
    let share = |(dx, dy, dth): (f64, f64, f64), f: f64| SimPose::new(dx * f, dy * f, dth * f);
    let mut pose = SimPose::default();
    let mut gaps = GapTracker::default();
    let mut last_delta = None;
    let mut readings = log.readings.iter().peekable();
    let mut frames = Vec::with_capacity(times.len());
    for (k, &t_s) in times.iter().enumerate() {
        while let Some(r) = readings.next_if(|r| r.t_s <= t_s + 1e-9) {
            let (_, fraction) = gaps.reading(r);
            pose = pose.compose(share(r.delta, fraction));
            last_delta = Some(r.delta);
        }
        // (A gap before the scan moves nothing here: the controller coasts across it.)
        let _ = gaps.scan(t_s);
        if let (Some(fraction), Some(delta)) = (gaps.lead(t_s), last_delta) {
            pose = pose.compose(share(delta, fraction));
        }
        frames.push(OdometryFrame {
            sequence: k as u32 + 1,
            time_us: (t_s * 1e6).round() as u64,
            x_m: pose.x_m as f32,
            y_m: pose.y_m as f32,
            theta_rad: pose.theta_rad as f32,
        });
    }
    Ok(frames)
}

/// The listening end of the vehicle port.
pub struct VehiclePort {
    listener: TcpListener,
}

impl VehiclePort {
    /// Listens on 127.0.0.1, any free port.
    pub fn bind() -> io::Result<Self> {
        Ok(Self {
            listener: TcpListener::bind((Ipv4Addr::LOCALHOST, 0))?,
        })
    }

    /// The port QEMU connects UART1 to.
    pub fn port(&self) -> u16 {
        self.listener.local_addr().map_or(0, |a| a.port())
    }

    /// Waits for QEMU, sends the [`start_frame`], then for each scan: sends its odometry
    /// frame, lets the scanner send the scan (`go`), and waits for the controller's pose
    /// frame (at most `timeout`).
    ///
    /// A controller that restarts instead (a watchdog reset: it then sends stale frames
    /// marked `after_reset` while it sets the scanner up again) has lost the scan it was
    /// sent, and the `outage_scans` after it while it comes back (the vehicle drives on):
    /// their entries are `None`, and the lock step goes on with the next one. `go` tells the
    /// scanner which scan to send.
    pub fn run(
        self,
        frames: &[OdometryFrame],
        go: &Sender<usize>,
        timeout: Duration,
        outage_scans: usize,
    ) -> Result<Vec<Option<PoseFrame>>, PortError> {
        let mut stream = accept(&self.listener, timeout)?;
        stream
            .set_read_timeout(Some(RESEND_EVERY))
            .map_err(PortError::Io)?;
        let mut buf = [0u8; MAX_ODOMETRY_FRAME_BYTES];
        stream
            .write_all(encode(&start_frame(), &mut buf)?)
            .map_err(PortError::Io)?;
        let mut assembler: FrameAssembler<MAX_FRAME_BYTES> = FrameAssembler::new();
        let mut poses = Vec::with_capacity(frames.len());
        // A restart already answered for (its stale frames go on until it tracks again).
        let mut restart_handled = false;
        let mut k = 0;
        while let Some(frame) = frames.get(k) {
            let bytes = encode(frame, &mut buf)?;
            stream.write_all(bytes).map_err(PortError::Io)?;
            if go.send(k).is_err() {
                return Err(PortError::NoPose { scan: k });
            }
            match next_pose(&mut stream, &mut assembler, bytes, timeout, restart_handled) {
                Some(Reply::Pose(pose)) => {
                    restart_handled &= pose.after_reset;
                    poses.push(Some(pose));
                }
                Some(Reply::Restarted) => {
                    restart_handled = true;
                    let lost = (outage_scans + 1).min(frames.len() - k);
                    poses.extend(std::iter::repeat_n(None, lost));
                    k += lost;
                    continue;
                }
                None => return Err(PortError::NoPose { scan: k }),
            }
            k += 1;
        }
        Ok(poses)
    }
}

/// `frame`'s bytes on the wire, in `buf`.
fn encode<'b>(
    frame: &OdometryFrame,
    buf: &'b mut [u8; MAX_ODOMETRY_FRAME_BYTES],
) -> Result<&'b [u8], PortError> {
    let bytes = frame
        .encode(buf)
        .map_err(|e| PortError::Io(io::Error::other(e.to_string())))?;
    Ok(&*bytes)
}

fn accept(listener: &TcpListener, timeout: Duration) -> Result<TcpStream, PortError> {
    listener.set_nonblocking(true).map_err(PortError::Io)?;
    let deadline = Instant::now() + timeout;
    loop {
        match listener.accept() {
            Ok((s, _)) => {
                s.set_nonblocking(false).map_err(PortError::Io)?;
                return Ok(s);
            }
            Err(e) if e.kind() == io::ErrorKind::WouldBlock && Instant::now() < deadline => {
                std::thread::sleep(Duration::from_millis(10));
            }
            Err(e) if e.kind() == io::ErrorKind::WouldBlock => {
                return Err(PortError::NoPose { scan: 0 })
            }
            Err(e) => return Err(PortError::Io(e)),
        }
    }
}

/// How often the scan's odometry frame is sent again while the controller works on the
/// scan (host time). A vehicle sends odometry at 50–100 Hz whatever the scanner does; without
/// the repeats a long telegram (CoLa-A under `-icount`, where QEMU moves one UART byte per
/// main-loop turn) would arrive more than the controller's 200 ms of virtual time after the
/// odometry, which it would then call stale.
const RESEND_EVERY: Duration = Duration::from_millis(20);

/// What the controller answered a scan with.
enum Reply {
    /// Its pose frame.
    Pose(PoseFrame),
    /// A stale frame marked `after_reset`: it restarted and waits for scans; the scan sent
    /// is lost.
    Restarted,
}

/// The next pose frame that answers a scan (stale and no-map frames, sent while waiting for
/// scans, are skipped; a stale frame marked `after_reset` is [`Reply::Restarted`] unless
/// `restart_handled`), or `None` after `timeout`; `odometry` (the scan's odometry frame) is
/// sent again every [`RESEND_EVERY`] meanwhile.
fn next_pose(
    stream: &mut TcpStream,
    assembler: &mut FrameAssembler<MAX_FRAME_BYTES>,
    odometry: &[u8],
    timeout: Duration,
    restart_handled: bool,
) -> Option<Reply> {
    let deadline = Instant::now() + timeout;
    // A byte at a time: whatever follows the pose frame stays in the socket for the next scan.
    let mut byte = [0u8; 1];
    while Instant::now() < deadline {
        match stream.read(&mut byte) {
            Ok(0) => return None,
            Ok(_) => {}
            Err(e)
                if matches!(
                    e.kind(),
                    io::ErrorKind::WouldBlock | io::ErrorKind::TimedOut
                ) =>
            {
                stream.write_all(odometry).ok()?;
                continue;
            }
            Err(_) => return None,
        };
        if let Assembled::Frame(f) = assembler.push(byte[0]) {
            if let Ok(pose) = PoseFrame::decode(f) {
                match pose.status {
                    PoseStatus::Stale if pose.after_reset && !restart_handled => {
                        return Some(Reply::Restarted)
                    }
                    PoseStatus::Stale | PoseStatus::NoMap => {}
                    _ => return Some(Reply::Pose(pose)),
                }
            }
        }
    }
    None
}

/// Writes the poses as an estimates file `replay --estimates` scores: one row per answered
/// scan at the scan's time (`times`, as [`scan_times`] read them; a scan lost to a restart
/// has no row, and the replay counts it missing).
pub fn write_estimates(
    path: &Path,
    times: &[f64],
    poses: &[Option<PoseFrame>],
) -> Result<(), String> {
    let mut text =
        String::from("t_s,est_x_m,est_y_m,est_theta_rad,sigma_x_m,sigma_y_m,sigma_theta_rad\n");
    for (t_s, p) in times
        .iter()
        .zip(poses)
        .filter_map(|(t, p)| p.as_ref().map(|p| (t, p)))
    {
        let c = p.covariance_upper;
        text.push_str(&format!(
            "{t_s:.6},{:.6},{:.6},{:.7},{:.6},{:.6},{:.7}\n",
            p.x_m,
            p.y_m,
            p.theta_rad,
            c[0].max(0.0).sqrt(),
            c[3].max(0.0).sqrt(),
            c[5].max(0.0).sqrt()
        ));
    }
    std::fs::write(path, text).map_err(|e| format!("cannot write {}: {e}", path.display()))
}

/// Writes every pose frame as the controller sent it, one row per scan: time, status, what
/// the prediction rested on, whether after a reset, and the work on the scan, end to end and
/// by stage (`work_scan` … `work_filter`).
pub fn write_frames(path: &Path, times: &[f64], poses: &[Option<PoseFrame>]) -> Result<(), String> {
    let mut text =
        String::from("scan,t_s,status,protection_m,availability,motion,after_reset,work");
    for name in controller_wire::STAGE_NAMES {
        text.push_str(&format!(",work_{name}"));
    }
    text.push('\n');
    for (k, (t_s, p)) in times.iter().zip(poses).enumerate() {
        let Some(p) = p else {
            text.push_str(&format!("{k},{t_s:.6},LostToReset,,,,,0"));
            for _ in controller_wire::STAGE_NAMES {
                text.push_str(",0");
            }
            text.push('\n');
            continue;
        };
        text.push_str(&format!(
            "{k},{t_s:.6},{:?},{:.4},{:?},{:?},{},{}",
            p.status, p.protection_m, p.availability, p.motion, p.after_reset, p.work
        ));
        for w in p.stage_work {
            text.push_str(&format!(",{w}"));
        }
        text.push('\n');
    }
    std::fs::write(path, text).map_err(|e| format!("cannot write {}: {e}", path.display()))
}
