//! # firmware-testbench: what checks the controller firmware on the target
//!
//! Not part of the product: the recorded fixtures (a synthetic 120 m tunnel's map, start
//! pose and LMS511 telegrams, written at build time by `build/record.rs`), the replay that
//! runs them through the very `Localizer` the controller runs (timing its stages through
//! loc-core's stage hook), and the binaries:
//!
//! - `bench`: instructions per scan per stage and end to end, checked against the budget;
//! - `selftest`: on-target tests printing `N passed, N failed`;
//! - `fault-check-panic`, `fault-check-hardfault`: the fault handlers' checks.
#![no_std]
#![warn(missing_docs)]

pub mod instruction_loop;
pub mod math_costs;
pub mod recorded;
pub mod replay;
pub mod stage_stats;
pub mod test_harness;
