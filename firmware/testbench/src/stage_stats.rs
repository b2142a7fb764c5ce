//! Per-stage costs of a scan, timed on the board's counter through loc-core's stage hook
//! ([`StageTimer`]), and their statistics over a run: count, mean and maximum in the board's
//! counter unit (instructions under QEMU, cycles on hardware).

use firmware::board::Board;
use loc_core::localizer::{Stage, StageObserver};

/// Running mean and maximum of one pipeline stage's cost per scan.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct StageStats {
    /// Scans measured.
    pub scans: u32,
    /// Sum of the per-scan costs, counter units.
    pub total: u64,
    /// Largest per-scan cost, counter units.
    pub max: u64,
}

impl StageStats {
    /// No scans yet.
    pub const fn new() -> Self {
        Self {
            scans: 0,
            total: 0,
            max: 0,
        }
    }

    /// Adds one scan's cost.
    pub fn record(&mut self, cost: u64) {
        self.scans = self.scans.saturating_add(1);
        self.total = self.total.saturating_add(cost);
        self.max = self.max.max(cost);
    }

    /// Mean cost per scan, counter units (0 before the first scan).
    pub fn mean(&self) -> u64 {
        if self.scans == 0 {
            0
        } else {
            self.total / u64::from(self.scans)
        }
    }
}

/// The stages of one scan as the benchmark reports them: the telegram's conversion into a
/// scan, loc-core's stages (seen through its [`StageObserver`] hook), and the filter (the
/// odometry prediction plus loc-core's update stage).
#[derive(Debug, Clone, Copy, PartialEq, Eq, defmt::Format)]
pub enum BenchStage {
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

impl BenchStage {
    /// Every stage, in execution order.
    pub const ALL: [BenchStage; 5] = [
        BenchStage::Scan,
        BenchStage::Strip,
        BenchStage::Select,
        BenchStage::Match,
        BenchStage::Filter,
    ];

    /// Short name for reports.
    pub const fn name(self) -> &'static str {
        match self {
            BenchStage::Scan => "scan",
            BenchStage::Strip => "strip",
            BenchStage::Select => "select",
            BenchStage::Match => "match",
            BenchStage::Filter => "filter",
        }
    }

    /// Where a loc-core stage is counted.
    pub const fn of(stage: Stage) -> Self {
        match stage {
            Stage::Strip => BenchStage::Strip,
            Stage::Select => BenchStage::Select,
            Stage::Match => BenchStage::Match,
            Stage::Update => BenchStage::Filter,
        }
    }
}

/// Cost of each stage for one scan, counter units, indexed like [`BenchStage::ALL`].
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct StageCosts(pub [u64; BenchStage::ALL.len()]);

impl StageCosts {
    /// Adds `cost` to `stage`.
    pub fn add(&mut self, stage: BenchStage, cost: u64) {
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
        self.costs.add(BenchStage::of(stage), cost);
    }
}
