//! The stages of [`super::Localizer::update_scan`] and the hook that sees them run.
//!
//! Benchmarks and the firmware time the stages through a [`StageObserver`] passed to
//! [`super::Localizer::update_scan_observed`], so what they measure is the very chain the
//! vehicle runs. `update_scan` passes `()`, whose empty methods compile to nothing.

/// One stage of the per-scan chain, in execution order.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stage {
    /// Wall stripping: RANSAC cubic walls and point labels ([`crate::strip::strip_walls`]).
    Strip,
    /// The points to match: the landmark points (up to a budget) and decimated wall points
    /// ([`crate::matching::select_match_points`]).
    Select,
    /// Landmark pre-alignment and scan-to-map matching
    /// ([`crate::matching::match_scan_with_prealign`]).
    Match,
    /// The EKF update on the observed directions ([`crate::filter::Ekf::update_with_match`]),
    /// the wall ends' fixes ([`crate::matching::observe_wall_ends`]) and the integrity check.
    Update,
}

impl Stage {
    /// Every stage, in execution order.
    pub const ALL: [Stage; 4] = [Stage::Strip, Stage::Select, Stage::Match, Stage::Update];

    /// Short name for reports.
    pub const fn name(self) -> &'static str {
        match self {
            Stage::Strip => "strip",
            Stage::Select => "select",
            Stage::Match => "match",
            Stage::Update => "update",
        }
    }

    /// Position in [`Stage::ALL`].
    pub const fn index(self) -> usize {
        self as usize
    }
}

/// Sees the stages of one scan: [`StageObserver::begin`] right before a stage runs,
/// [`StageObserver::end`] right after it. A stage that is not reached (the match failed, so
/// no update) is not reported. Both default to doing nothing.
pub trait StageObserver {
    /// `stage` is about to run.
    #[inline(always)]
    fn begin(&mut self, stage: Stage) {
        let _ = stage;
    }

    /// `stage` has finished.
    #[inline(always)]
    fn end(&mut self, stage: Stage) {
        let _ = stage;
    }
}

/// No observer: [`super::Localizer::update_scan`].
impl StageObserver for () {}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn indices_follow_the_execution_order() {
        for (i, s) in Stage::ALL.iter().enumerate() {
            assert_eq!(s.index(), i);
        }
    }
}
