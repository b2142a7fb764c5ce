//! The steps of the LMS5xx start-up sequence, in order: the request each sends, the answer it
//! waits for, and which steps the configuration skips.

use core::fmt;

use crate::request::{names, Request};
use crate::telegram::CommandType;

use super::config::SessionConfig;

/// One request/answer exchange of the start-up sequence (see the telegram notes, "Starting an
/// LMS5xx"). Order: [`Step::FIRST_AFTER_PROBE`], then [`Step::next`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Step {
    /// `sRN SCdevicestate` in one dialect, to find which one the sensor speaks.
    Probe,
    /// `sRN SCdevicestate` repeated while the device reports busy or error.
    WaitReady,
    /// `sMN SetAccessMode level password`.
    Login,
    /// `sWN EIHstCola` to the configured dialect, then re-connect (only when the sensor speaks
    /// the other one and [`SessionConfig::switch_dialect`] asks for it).
    SwitchDialect,
    /// `sRN FirmwareVersion`.
    ReadFirmwareVersion,
    /// `sRN SCdevicestate` after login (busy is normal here: configuration mode).
    ReadDeviceState,
    /// `sRN LocationName`.
    ReadLocationName,
    /// `sWN LMPoutputRange` (configured only).
    WriteOutputRange,
    /// `sRN LMPoutputRange`.
    ReadOutputRange,
    /// `sWN LMDscandatacfg`.
    WriteScanDataConfig,
    /// `sRN LMDscandatacfg`.
    ReadScanDataConfig,
    /// `sMN mLMPsetscancfg` (configured only).
    SetScanConfig,
    /// `sRN LMPscancfg` (after [`Step::SetScanConfig`]).
    ReadScanConfig,
    /// `sWN FREchoFilter` (configured only).
    WriteEchoFilter,
    /// `sMN LMCstartmeas`.
    StartMeasurement,
    /// `sMN Run`.
    Run,
    /// `sEN LMDscandata 1`.
    Subscribe,
}

impl Step {
    /// The step after a successful probe / ready wait.
    pub const FIRST_AFTER_PROBE: Step = Step::Login;

    /// The request this step sends.
    pub fn request(self, cfg: &SessionConfig) -> Request<'static> {
        match self {
            Step::Probe | Step::WaitReady | Step::ReadDeviceState => {
                Request::Read(names::DEVICE_STATE)
            }
            Step::Login => Request::SetAccessMode {
                level: cfg.access_level.level(),
                password: cfg
                    .password
                    .unwrap_or_else(|| cfg.access_level.default_password()),
            },
            Step::SwitchDialect => {
                Request::SetHostDialect(cfg.switch_dialect.unwrap_or(cfg.first_dialect))
            }
            Step::ReadFirmwareVersion => Request::Read(names::FIRMWARE_VERSION),
            Step::ReadLocationName => Request::Read(names::LOCATION_NAME),
            Step::WriteOutputRange => match cfg.output_range {
                Some(r) => Request::SetOutputRange(r),
                None => Request::Read(names::OUTPUT_RANGE),
            },
            Step::ReadOutputRange => Request::Read(names::OUTPUT_RANGE),
            Step::WriteScanDataConfig => Request::SetScanDataConfig(cfg.scan_data),
            Step::ReadScanDataConfig => Request::Read(names::SCAN_DATA_CONFIG),
            Step::SetScanConfig => match cfg.scan_config {
                Some(c) => Request::SetScanConfig(c),
                None => Request::Read(names::SCAN_CONFIG),
            },
            Step::ReadScanConfig => Request::Read(names::SCAN_CONFIG),
            Step::WriteEchoFilter => match cfg.echo_filter {
                Some(f) => Request::SetEchoFilter(f),
                None => Request::Read(names::ECHO_FILTER),
            },
            Step::StartMeasurement => Request::StartMeasurement,
            Step::Run => Request::Run,
            Step::Subscribe => Request::SUBSCRIBE_SCANS,
        }
    }

    /// Command type and name of the answer this step waits for (`sFA` is always accepted as the
    /// answer too). A method may first answer `sMA` (accepted), then `sAN`.
    pub fn expected_answer(self, cfg: &SessionConfig) -> (CommandType, &'static str) {
        let (kind, name) = self.request(cfg).header();
        let answer = match kind {
            CommandType::ReadRequest => CommandType::ReadAnswer,
            CommandType::WriteRequest => CommandType::WriteAnswer,
            CommandType::MethodRequest => CommandType::MethodAnswer,
            _ => CommandType::EventAnswer,
        };
        (answer, name)
    }

    /// The step after this one for this configuration; `None` after [`Step::Subscribe`].
    pub fn next(self, cfg: &SessionConfig) -> Option<Step> {
        let mut s = self.successor()?;
        loop {
            let skip = match s {
                Step::WriteOutputRange => cfg.output_range.is_none(),
                Step::SetScanConfig | Step::ReadScanConfig => cfg.scan_config.is_none(),
                Step::WriteEchoFilter => cfg.echo_filter.is_none(),
                _ => false,
            };
            if !skip {
                return Some(s);
            }
            s = s.successor()?;
        }
    }

    fn successor(self) -> Option<Step> {
        Some(match self {
            Step::Probe | Step::WaitReady => Step::Login,
            Step::Login | Step::SwitchDialect => Step::ReadFirmwareVersion,
            Step::ReadFirmwareVersion => Step::ReadDeviceState,
            Step::ReadDeviceState => Step::ReadLocationName,
            Step::ReadLocationName => Step::WriteOutputRange,
            Step::WriteOutputRange => Step::ReadOutputRange,
            Step::ReadOutputRange => Step::WriteScanDataConfig,
            Step::WriteScanDataConfig => Step::ReadScanDataConfig,
            Step::ReadScanDataConfig => Step::SetScanConfig,
            Step::SetScanConfig => Step::ReadScanConfig,
            Step::ReadScanConfig => Step::WriteEchoFilter,
            Step::WriteEchoFilter => Step::StartMeasurement,
            Step::StartMeasurement => Step::Run,
            Step::Run => Step::Subscribe,
            Step::Subscribe => return None,
        })
    }

    /// What the step does, for logs and error messages.
    pub fn describe(self) -> &'static str {
        match self {
            Step::Probe => "dialect probe (sRN SCdevicestate)",
            Step::WaitReady => "waiting for the device to become ready (sRN SCdevicestate)",
            Step::Login => "login (sMN SetAccessMode)",
            Step::SwitchDialect => "switching the sensor's dialect (sWN EIHstCola)",
            Step::ReadFirmwareVersion => "reading FirmwareVersion",
            Step::ReadDeviceState => "reading SCdevicestate",
            Step::ReadLocationName => "reading LocationName",
            Step::WriteOutputRange => "writing LMPoutputRange",
            Step::ReadOutputRange => "reading LMPoutputRange",
            Step::WriteScanDataConfig => "writing LMDscandatacfg",
            Step::ReadScanDataConfig => "reading LMDscandatacfg",
            Step::SetScanConfig => "setting frequency and resolution (sMN mLMPsetscancfg)",
            Step::ReadScanConfig => "reading LMPscancfg",
            Step::WriteEchoFilter => "writing FREchoFilter",
            Step::StartMeasurement => "starting measurement (sMN LMCstartmeas)",
            Step::Run => "leaving configuration mode (sMN Run)",
            Step::Subscribe => "subscribing to scans (sEN LMDscandata 1)",
        }
    }
}

impl fmt::Display for Step {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.describe())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::request::{EchoFilter, ScanConfig};

    fn sequence(cfg: &SessionConfig) -> Vec<Step> {
        let mut v = vec![Step::FIRST_AFTER_PROBE];
        while let Some(n) = v.last().and_then(|s| s.next(cfg)) {
            v.push(n);
        }
        v
    }

    #[test]
    fn default_sequence_skips_optional_steps() {
        let s = sequence(&SessionConfig::default());
        assert_eq!(
            s,
            [
                Step::Login,
                Step::ReadFirmwareVersion,
                Step::ReadDeviceState,
                Step::ReadLocationName,
                Step::ReadOutputRange,
                Step::WriteScanDataConfig,
                Step::ReadScanDataConfig,
                Step::StartMeasurement,
                Step::Run,
                Step::Subscribe
            ]
        );
    }

    #[test]
    fn full_sequence_and_expected_answers() {
        let cfg = SessionConfig {
            output_range: Some(crate::request::OutputRange {
                sectors: 1,
                step_1e4_deg: 1667,
                start_1e4_deg: -50000,
                stop_1e4_deg: 1_850_000,
            }),
            scan_config: Some(ScanConfig {
                frequency_1e2_hz: 2500,
                sectors: 1,
                step_1e4_deg: 1667,
                start_1e4_deg: -50000,
                stop_1e4_deg: 1_850_000,
            }),
            echo_filter: Some(EchoFilter::First),
            ..SessionConfig::default()
        };
        let s = sequence(&cfg);
        assert_eq!(s.len(), 14);
        assert_eq!(
            Step::SetScanConfig.expected_answer(&cfg),
            (CommandType::MethodAnswer, "mLMPsetscancfg")
        );
        assert_eq!(
            Step::Subscribe.expected_answer(&cfg),
            (CommandType::EventAnswer, "LMDscandata")
        );
        assert_eq!(
            Step::WriteOutputRange.expected_answer(&cfg),
            (CommandType::WriteAnswer, "LMPoutputRange")
        );
    }
}
