//! Statistics of the per-stage costs over a run (the costs themselves are the product's:
//! `firmware::stage_costs`): count, mean and maximum in the board's counter unit
//! (instructions under QEMU, cycles on hardware).

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
