//! [`LocalizerConfig`]: everything a [`super::Localizer`] is tuned by, and the wall range it
//! derives from the prediction's uncertainty.

use nalgebra::Matrix3;

use super::integrity::IntegrityConfig;
use super::largest_position_sd_m;
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
    /// Wall points kept for matching (landmark points are all kept).
    pub max_wall_points: u16,
    /// Wall points farther than `wall_range_scale_m2 / σ` are not matched, where σ is the
    /// predicted position's largest standard deviation (metres; in a smooth tunnel the
    /// along-tunnel one): with the position along the tunnel uncertain by σ, the stored
    /// walls far ahead may bend where the scanned ones do not (or run straight where they
    /// bend), and those points bias the lateral and heading fit. m².
    pub wall_range_scale_m2: f32,
    /// The wall range above never drops below this, metres (near walls fix the lateral
    /// position and the heading).
    pub min_wall_range_m: f32,
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
}

impl LocalizerConfig {
    /// The defaults (what [`Default`] gives), usable in `const` and `static` items.
    pub const DEFAULT: Self = Self {
        sensor: SensorSetup::DEFAULT,
        strip: StripConfig::DEFAULT,
        max_wall_points: 100,
        wall_range_scale_m2: 10.0,
        min_wall_range_m: 15.0,
        prealign: PrealignConfig::DEFAULT,
        matching: MatchConfig::DEFAULT,
        wall_end: WallEndConfig::DEFAULT,
        odometry: OdometryNoise::DEFAULT,
        coast: CoastNoise::DEFAULT,
        update: UpdateConfig::DEFAULT,
        integrity: IntegrityConfig::DEFAULT,
        relocalise: RelocaliseConfig::DEFAULT,
        protection: ProtectionConfig::DEFAULT,
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

    /// How far out wall points are matched for a prediction with position covariance
    /// `covariance` (see [`LocalizerConfig::wall_range_scale_m2`]), metres;
    /// `f32::INFINITY` when the prediction is certain (or the covariance is not finite).
    pub fn wall_range_m(&self, covariance: &Matrix3<f32>) -> f32 {
        let sd_m = largest_position_sd_m(covariance);
        if sd_m > 0.0 && sd_m.is_finite() {
            crate::math::max(self.wall_range_scale_m2 / sd_m, self.min_wall_range_m)
        } else {
            f32::INFINITY
        }
    }
}
