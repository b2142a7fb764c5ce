//! The simulated LMS511's `sSN LMDscandata` telegrams, byte for byte as the real scanner
//! streams them in CoLa-B (built as lidar-driver's [`ScanRepr`] and emitted by it).
//!
//! Header fields follow the real LMS511 capture in `lidar-driver/captures` (firmware V1.80):
//! version 0, device number 1, device status `01 00` on the first scan of the stream then
//! `00 00`, the scan counter counting scans since power-up and the telegram counter counting
//! streamed telegrams, time since start-up in µs at the first shot (wrapping after 71.6 min),
//! time of transmission one scan period plus 0.85 ms later (the capture shows 40.85 ms at
//! 25 Hz), the frequency pair of the scan rate (scan frequency in 1/100 Hz; shot frequency
//! `f · 360° / step` in 100 Hz units: 540 = 54 kHz at 25 Hz / 0.1667°), no encoders, the
//! five 16-bit distance channels `DIST1`…`DIST5` of a scanner set up for all five echoes
//! (`LMDscandatacfg` output channel `0x1F`; each with the scan's layout and scale: start
//! −5° = −50000, step in 1/10000°, one raw value per beam; scale 1 mm, or 2 mm for a scan
//! with an echo beyond 65.534 m; echo `n` of a beam in `DISTn`, in range order, 0 where the
//! beam has fewer than `n` echoes), and the time block of the scanner's clock.
//! No `RSSI` channels: the simulator has no remission model, so the simulated scanner is set
//! up with remission output off (`LMDscandatacfg` remission flag 0), which a real LMS511
//! accepts.

use lidar_driver::scandata::TimeBlock;
use lidar_driver::{ChannelRepr, CommandType, Dialect, EmitError, ScanHeader, ScanRepr};

use crate::lidar::{LidarScan, ScanRate, MAX_ECHOES};

/// `LMDscandatacfg` output channel of a scanner set up for all five echoes: bit `n − 1`
/// enables echo `n` (what the simulated scanner sends where there is dust).
pub const OUTPUT_CHANNEL_ECHOES: u16 = 0x1F;

/// `LMDscandatacfg` output channel of a scanner set up for the first echo alone (DIST1:
/// what the simulated scanner sends in clear air, as the firmware's session asks for it).
pub const OUTPUT_CHANNEL_FIRST_ECHO: u16 = 0x01;

/// The output channel the simulated scanner is set up with: all five echoes when there is
/// dust in front of it (the scenario's `lidar.dust.fraction` above 0), else the first echo
/// alone (one beam, one echo: four empty channels would quintuple a recording for nothing).
pub fn output_channel_for(dust_fraction: f64) -> u16 {
    if dust_fraction > 0.0 {
        OUTPUT_CHANNEL_ECHOES
    } else {
        OUTPUT_CHANNEL_FIRST_ECHO
    }
}

/// Serial number of the simulated scanner (the telegram's serial field).
pub const SIMULATED_SERIAL: u32 = 99_000_511;

/// Time the simulated scanner has been powered up when the run starts, seconds.
pub const POWER_UP_BEFORE_RUN_S: f64 = 60.0;

/// Gap between the first shot of a scan and its transmission beyond one scan period, µs.
const TRANSMISSION_LAG_US: u32 = 850;

/// The scanner's real-time clock at the start of the run: 2026-01-01 00:00:00 (the time
/// block; nothing in the localiser reads it).
pub const CLOCK_AT_RUN_START: (u16, u8, u8) = (2026, 1, 1);

/// Turns simulated scans into the telegrams the LMS511 would stream for them.
#[derive(Debug, Clone)]
pub struct Lms511Telegrams {
    rate: ScanRate,
    output_channel: u16,
    serial: u32,
    telegrams_sent: u32,
}

impl Lms511Telegrams {
    /// A scanner streaming at `rate`, all five echoes enabled ([`OUTPUT_CHANNEL_ECHOES`]).
    pub fn new(rate: ScanRate) -> Self {
        Self::with_output_channel(rate, OUTPUT_CHANNEL_ECHOES)
    }

    /// A scanner streaming at `rate` the echoes `output_channel` enables (`LMDscandatacfg`:
    /// bit `n − 1` for echo `n`).
    pub fn with_output_channel(rate: ScanRate, output_channel: u16) -> Self {
        Self {
            rate,
            output_channel,
            serial: SIMULATED_SERIAL,
            telegrams_sent: 0,
        }
    }

    /// The owned telegram of a scan taken `scan.t_s` seconds into the run. Counters advance.
    pub fn next_repr(&mut self, scan: &LidarScan) -> ScanRepr {
        let f = self.rate.frequency_hz();
        let since_power_up_s = POWER_UP_BEFORE_RUN_S + scan.t_s.max(0.0);
        // The LMS5xx stamps a scan at its first shot; `t_s` is its last beam's time.
        let first_shot_s = since_power_up_s - scan.layout.sweep_s();
        let startup_us = (first_shot_s * 1e6).round() as u64;
        // Counters and the µs clock are u32/u16 fields on the wire: they wrap.
        let startup_us_u32 = (startup_us % (1u64 << 32)) as u32;
        let period_us = (1e6 / f).round() as u32;
        let scans_since_power_up = (since_power_up_s * f).round() as u64;
        let first = self.telegrams_sent == 0;
        self.telegrams_sent = self.telegrams_sent.wrapping_add(1);
        let header = ScanHeader {
            version: 0,
            device_number: 1,
            serial_number: self.serial,
            device_status: if first { [1, 0] } else { [0, 0] },
            telegram_counter: self.telegram_counter(),
            scan_counter: (scans_since_power_up % 65_536) as u16,
            time_since_startup_us: startup_us_u32,
            time_of_transmission_us: startup_us_u32
                .wrapping_add(period_us)
                .wrapping_add(TRANSMISSION_LAG_US),
            input_status: [0, 0],
            output_status: [0, 0],
            reserved_layer_angle: 0,
            scan_frequency_1e2_hz: scan.layout.scan_frequency_1e2_hz,
            measurement_frequency_100hz: scan.layout.measurement_frequency_100hz,
        };
        let beams = scan.beams();
        let distance = (0..MAX_ECHOES)
            .filter(|k| self.output_channel & (1 << k) != 0)
            .map(|k| ChannelRepr {
                name: *b"DIST1",
                scale_factor: scan.scale_factor,
                scale_offset: scan.scale_offset_mm,
                start_angle_1e4_deg: scan.layout.start_angle_1e4_deg,
                step_1e4_deg: scan.layout.step_1e4_deg,
                values: scan
                    .echoes
                    .get(k)
                    .cloned()
                    .unwrap_or_else(|| vec![0; beams]),
            })
            .enumerate()
            .map(|(k, mut c)| {
                c.name[4] = b'1' + k as u8;
                c
            })
            .collect();
        ScanRepr {
            command_type: CommandType::Event,
            header,
            encoders: Vec::new(),
            channels16: distance,
            channels8: Vec::new(),
            position: None,
            device_name: None,
            comment: None,
            time: Some(clock_at(scan.t_s)),
            event: None,
        }
    }

    /// The telegram counter of the last telegram made (the scanner's u16 count of telegrams
    /// sent, wrapping; 0 before the first).
    pub fn telegram_counter(&self) -> u16 {
        (self.telegrams_sent % 65_536) as u16
    }

    /// The CoLa-B frame of a scan (STX STX STX STX, length, payload, XOR checksum).
    pub fn next_frame(&mut self, scan: &LidarScan) -> Result<Vec<u8>, EmitError> {
        self.next_repr(scan).to_vec(Dialect::ColaB)
    }
}

/// The scanner's clock `t_s` seconds into the run (from [`CLOCK_AT_RUN_START`]).
fn clock_at(t_s: f64) -> TimeBlock {
    let us_total = (t_s.max(0.0) * 1e6).round() as u64;
    let secs = us_total / 1_000_000;
    let days = secs / 86_400;
    let (y, m, d) = civil_from_days(days_from_civil(CLOCK_AT_RUN_START) + days as i64);
    let sod = secs % 86_400;
    TimeBlock {
        year: y,
        month: m,
        day: d,
        hour: (sod / 3600) as u8,
        minute: (sod / 60 % 60) as u8,
        second: (sod % 60) as u8,
        microsecond: (us_total % 1_000_000) as u32,
    }
}

/// Days since 1970-01-01 of a proleptic Gregorian date (H. Hinnant's algorithm).
fn days_from_civil((y, m, d): (u16, u8, u8)) -> i64 {
    let (m, d) = (i64::from(m), i64::from(d));
    let y = i64::from(y) - i64::from(m <= 2);
    let era = y.div_euclid(400);
    let yoe = y - era * 400;
    let doy = (153 * (m + if m > 2 { -3 } else { 9 }) + 2) / 5 + d - 1;
    let doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
    era * 146_097 + doe - 719_468
}

/// The date of a day count since 1970-01-01 (inverse of [`days_from_civil`]).
fn civil_from_days(z: i64) -> (u16, u8, u8) {
    let z = z + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + i64::from(m <= 2);
    (y.clamp(0, 65_535) as u16, m as u8, d as u8)
}

#[cfg(test)]
mod tests {
    use super::*;
    use lidar_driver::recording::Recording;
    use lidar_driver::{Framer, ScanData};

    fn scan(t_s: f64, rate: ScanRate) -> LidarScan {
        LidarScan {
            t_s,
            echoes: vec![(0..rate.beam_count()).map(|i| (1000 + i) as u16).collect()],
            scale_factor: 1.0,
            scale_offset_mm: 0.0,
            layout: rate.layout(),
        }
    }

    /// The first scan of the real LMS511 capture (firmware V1.80).
    fn real_first_scan() -> ScanRepr {
        let path = sick_captures::path(sick_captures::LMS511_S2H);
        let rec = Recording::read_file(&path).expect("the real LMS511 capture");
        let frames = rec.frames();
        let f = frames
            .frames
            .iter()
            .find_map(|f| {
                ScanData::new_checked(f.frame())
                    .ok()
                    .map(|s| ScanRepr::parse(&s))
            })
            .expect("a scan in the capture");
        f
    }

    #[test]
    fn telegram_has_the_layout_of_a_real_lms511_scan() {
        let real = real_first_scan();
        let mut t = Lms511Telegrams::new(ScanRate::Hz25);
        let ours = t.next_repr(&scan(0.04, ScanRate::Hz25));
        let (r, o) = (&real.header, &ours.header);
        assert_eq!(o.version, r.version);
        assert_eq!(o.device_number, r.device_number);
        assert_eq!(o.device_status, r.device_status);
        assert_eq!(o.scan_frequency_1e2_hz, r.scan_frequency_1e2_hz);
        assert_eq!(o.measurement_frequency_100hz, r.measurement_frequency_100hz);
        assert_eq!(ours.command_type, real.command_type);
        assert_eq!(ours.encoders, real.encoders);
        let (rd, od) = (&real.channels16[0], &ours.channels16[0]);
        assert_eq!(
            (od.name, od.scale_factor, od.scale_offset),
            (rd.name, rd.scale_factor, rd.scale_offset)
        );
        assert_eq!(od.start_angle_1e4_deg, rd.start_angle_1e4_deg);
        assert_eq!(od.step_1e4_deg, rd.step_1e4_deg);
        assert_eq!(od.values.len(), rd.values.len());
        assert_eq!(ours.time.is_some(), real.time.is_some());
        // Transmission lag like the real one (40.85 ms at 25 Hz).
        let lag = o.time_of_transmission_us - o.time_since_startup_us;
        let real_lag = r.time_of_transmission_us - r.time_since_startup_us;
        assert!(lag.abs_diff(real_lag) < 100, "{lag} vs {real_lag}");
        // The real scan (3553 bytes) carries DIST1 and RSSI1 (21 + 1141 bytes); these carry
        // DIST1…DIST5 (21 + 2 · 1141 bytes each) and no RSSI.
        let bytes = ours.to_vec(Dialect::ColaB).unwrap();
        assert_eq!(bytes.len(), 3553 - 21 - 1141 + 4 * (21 + 2 * 1141));
        let names: Vec<&[u8]> = ours.channels16.iter().map(|c| &c.name[..]).collect();
        assert_eq!(names, [b"DIST1", b"DIST2", b"DIST3", b"DIST4", b"DIST5"]);
    }

    #[test]
    fn frames_decode_back_with_counters_clock_and_every_rate() {
        for rate in [
            ScanRate::Hz25,
            ScanRate::Hz35,
            ScanRate::Hz50,
            ScanRate::Hz75,
            ScanRate::Hz100,
        ] {
            let mut t = Lms511Telegrams::new(rate);
            let period = 1.0 / rate.frequency_hz();
            let mut stream = Vec::new();
            let scans: Vec<LidarScan> = (1..=3).map(|k| scan(k as f64 * period, rate)).collect();
            for s in &scans {
                stream.extend(t.next_frame(s).unwrap());
            }
            let mut framer = Framer::new(vec![0u8; 16384]);
            let mut decoded = Vec::new();
            framer.feed(&stream, |f| {
                let s = ScanData::new_checked(f.unwrap()).unwrap();
                decoded.push(ScanRepr::parse(&s));
            });
            assert_eq!(decoded.len(), 3);
            for (k, (d, s)) in decoded.iter().zip(&scans).enumerate() {
                assert_eq!(d.channels16[0].values, s.dist1());
                assert_eq!(d.channels16.len(), 5);
                assert!(d.channels16[1..]
                    .iter()
                    .all(|c| c.values.iter().all(|&v| v == 0)));
                assert_eq!(d.channels16[0].step_1e4_deg as u32, rate.step_1e4_deg());
                assert_eq!(d.header.device_status, if k == 0 { [1, 0] } else { [0, 0] });
                assert_eq!(d.header.telegram_counter as usize, k + 1);
                let dt = d.header.time_since_startup_us - decoded[0].header.time_since_startup_us;
                // Each time is rounded to the µs on its own.
                assert!((f64::from(dt) - k as f64 * period * 1e6).abs() <= 1.0);
            }
            let sc: Vec<u16> = decoded.iter().map(|d| d.header.scan_counter).collect();
            assert_eq!((sc[1] - sc[0], sc[2] - sc[1]), (1, 1));
        }
        assert_eq!(ScanRate::Hz25.measurement_frequency_100hz(), 540);
        assert_eq!(ScanRate::Hz35.measurement_frequency_100hz(), 504);
        assert_eq!(ScanRate::Hz100.measurement_frequency_100hz(), 540);
    }

    #[test]
    fn clock_rolls_over_days_and_months() {
        let c = clock_at(31.0 * 86_400.0 + 3661.25);
        assert_eq!((c.year, c.month, c.day), (2026, 2, 1));
        assert_eq!(
            (c.hour, c.minute, c.second, c.microsecond),
            (1, 1, 1, 250_000)
        );
        assert_eq!(
            civil_from_days(days_from_civil((2024, 2, 29))),
            (2024, 2, 29)
        );
    }
}
