//! [`LocalizerConfig`]: everything a [`super::Localizer`] is tuned by.

use super::integrity::IntegrityConfig;
use super::protection::ProtectionConfig;
use crate::filter::{CoastNoise, OdometryNoise, UpdateConfig};
use crate::matching::{MatchConfig, PrealignConfig, WallEndConfig};
use crate::relocalise::RelocaliseConfig;
use crate::scan::SensorSetup;
use crate::strip::StripConfig;

/// Everything a [`super::Localizer`] is tuned by.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct LocalizerConfig {
    /// The scanner's beam layout and mounting on the vehicle. Informational for the
    /// localizer (scans arrive as [`crate::scan::Scan`]s already in the vehicle frame); build scans with
    /// the same setup.
    pub sensor: SensorSetup,
    /// Wall stripping.
    pub strip: StripConfig,
    /// Wall points kept for matching (each the mean of a run of the wall's points).
    pub max_wall_points: u16,
    /// Landmark points kept for matching, spread evenly over the scan's landmark points
    /// when it has more (each costs a map search and a share of every iteration).
    pub max_landmark_points: u16,
    /// Along-tunnel pre-alignment on landmarks.
    pub prealign: PrealignConfig,
    /// Matcher choice (Hausdorff | ICP), K fraction, range noise, iteration limits.
    pub matching: MatchConfig,
    /// The along-tunnel position from where the walls end (portals, faces).
    pub wall_end: WallEndConfig,
    /// Odometry noise model and step limits.
    pub odometry: OdometryNoise,
    /// Motion uncertainty while no odometry arrives ([`super::Localizer::coast`]).
    pub coast: CoastNoise,
    /// Chi-square gate probability and measurement floor of the match update (which
    /// directions a match observes is `matching`'s judgement).
    pub update: UpdateConfig,
    /// When the map explains a scan well enough to use its match.
    pub integrity: IntegrityConfig,
    /// Global relocalisation on the landmarks' spacing, and when the localizer declares
    /// itself lost.
    pub relocalise: RelocaliseConfig,
    /// The integrity risk, alert limit and fault bounds of the protection level.
    pub protection: ProtectionConfig,
    /// Whether a scan's points are carried to its last beam over the scanner's sweep
    /// ([`crate::scan::Scan::deskew`], at the filter's speed since the last scan). On for
    /// every real LMS5xx, whose beams of a 25 Hz scan span 21 ms; off only for scans taken
    /// at one instant (a simulator without the sweep). Scans without a
    /// [`crate::scan::ScanTiming`] are never de-skewed.
    pub deskew: bool,
}

impl LocalizerConfig {
    /// The defaults (what [`Default`] gives), usable in `const` and `static` items.
    pub const DEFAULT: Self = Self {
        sensor: SensorSetup::DEFAULT,
        strip: StripConfig::DEFAULT,
        max_wall_points: 100,
        max_landmark_points: 64,
        prealign: PrealignConfig::DEFAULT,
        matching: MatchConfig::DEFAULT,
        wall_end: WallEndConfig::DEFAULT,
        odometry: OdometryNoise::DEFAULT,
        coast: CoastNoise::DEFAULT,
        update: UpdateConfig::DEFAULT,
        integrity: IntegrityConfig::DEFAULT,
        relocalise: RelocaliseConfig::DEFAULT,
        protection: ProtectionConfig::DEFAULT,
        deskew: true,
    };
}

impl Default for LocalizerConfig {
    fn default() -> Self {
        Self::DEFAULT
    }
}

impl LocalizerConfig {
    /// The default configuration with `matcher` (Hausdorff or PL-ICP).
    pub fn with_matcher(matcher: crate::matching::MatcherKind) -> Self {
        let mut c = Self::default();
        c.matching.matcher = matcher;
        c
    }
}
