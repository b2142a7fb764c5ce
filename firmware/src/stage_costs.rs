//! The cost of each stage of a scan on the board's counter: the telegram's conversion, loc-core's
//! stages (through its [`StageObserver`] hook, timed by [`StageTimer`]) and the filter. The
//! controller puts them in every pose frame (`PoseFrame::stage_work`); the testbench's bench
//! reports their statistics.

use crate::board::Board;
use loc_core::localizer::{Stage, StageObserver};

/// The stages of one scan as the controller reports them (each pose frame's `stage_work`)
/// and the benchmark times them: the telegram's conversion into a
/// scan, loc-core's stages (seen through its [`StageObserver`] hook), and the filter (the
/// odometry prediction plus loc-core's update stage).
#[derive(Debug, Clone, Copy, PartialEq, Eq, defmt::Format)]
pub enum ScanStage {
    /// `LMDscandata` decode and `scan_input::load_scan` (telegram to vehicle-frame points).
    Scan,
    /// [`Stage::Strip`].
    Strip,
    /// [`Stage::Select`].
    Select,
    /// [`Stage::Match`].
    Match,
    /// The odometry prediction and [`Stage::Update`].
    Filter,
}

impl ScanStage {
    /// Every stage, in execution order.
    pub const ALL: [ScanStage; 5] = [
        ScanStage::Scan,
        ScanStage::Strip,
        ScanStage::Select,
        ScanStage::Match,
        ScanStage::Filter,
    ];

    /// Short name for reports.
    pub const fn name(self) -> &'static str {
        match self {
            ScanStage::Scan => "scan",
            ScanStage::Strip => "strip",
            ScanStage::Select => "select",
            ScanStage::Match => "match",
            ScanStage::Filter => "filter",
        }
    }

    /// Where a loc-core stage is counted.
    pub const fn of(stage: Stage) -> Self {
        match stage {
            Stage::Strip => ScanStage::Strip,
            Stage::Select => ScanStage::Select,
            Stage::Match => ScanStage::Match,
            Stage::Update => ScanStage::Filter,
        }
    }
}

/// Cost of each stage for one scan, counter units, indexed like [`ScanStage::ALL`].
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct StageCosts(pub [u64; ScanStage::ALL.len()]);

impl StageCosts {
    /// Adds `cost` to `stage`.
    pub fn add(&mut self, stage: ScanStage, cost: u64) {
        if let Some(c) = self.0.get_mut(stage as usize) {
            *c += cost;
        }
    }

    /// Sum over the stages.
    pub fn total(&self) -> u64 {
        self.0.iter().sum()
    }
}

/// Times loc-core's stages on the board's counter, as `Localizer::update_scan_observed`
/// runs them.
pub struct StageTimer<'b, B: Board> {
    board: &'b B,
    started: u64,
    /// The costs so far.
    pub costs: StageCosts,
}

impl<'b, B: Board> StageTimer<'b, B> {
    /// A timer reading `board`'s counter, all costs zero.
    pub fn new(board: &'b B) -> Self {
        Self {
            board,
            started: 0,
            costs: StageCosts::default(),
        }
    }
}

impl<B: Board> StageObserver for StageTimer<'_, B> {
    fn begin(&mut self, _stage: Stage) {
        self.started = self.board.counter_now();
    }

    fn end(&mut self, stage: Stage) {
        let cost = self.board.counter_now() - self.started;
        self.costs.add(ScanStage::of(stage), cost);
    }
}

impl<B: Board> StageTimer<'_, B> {
    /// The board's counter now.
    pub fn now(&self) -> u64 {
        self.board.counter_now()
    }

    /// Adds the counter's advance since `since` to `stage`.
    pub fn add_since(&mut self, stage: ScanStage, since: u64) {
        let cost = self.board.counter_now() - since;
        self.costs.add(stage, cost);
    }
}

impl StageCosts {
    /// The costs as a pose frame carries them (`PoseFrame::stage_work`, saturated to u32).
    pub fn to_wire(&self) -> [u32; 5] {
        self.0.map(|c| u32::try_from(c).unwrap_or(u32::MAX))
    }
}
