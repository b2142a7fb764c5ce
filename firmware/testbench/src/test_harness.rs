//! A minimal on-target test runner: runs named test functions, logs each result, and prints
//! the `N passed, N failed` line CI reads (defmt-test prints no such summary).

/// Why a test failed: a static message naming what was expected.
pub type TestResult = Result<(), &'static str>;

/// Counts passes and failures over a sequence of tests.
#[derive(Debug, Default)]
pub struct TestRunner {
    passed: u32,
    failed: u32,
}

impl TestRunner {
    /// A runner with no results yet.
    pub const fn new() -> Self {
        Self {
            passed: 0,
            failed: 0,
        }
    }

    /// Runs `test` and records its result under `name`.
    pub fn run(&mut self, name: &str, test: impl FnOnce() -> TestResult) {
        match test() {
            Ok(()) => {
                self.passed += 1;
                defmt::println!("test {=str} ... ok", name);
            }
            Err(why) => {
                self.failed += 1;
                defmt::println!("test {=str} ... FAILED: {=str}", name, why);
            }
        }
    }

    /// Prints the summary line and returns true when no test failed.
    pub fn finish(&self) -> bool {
        defmt::println!("{=u32} passed, {=u32} failed", self.passed, self.failed);
        self.failed == 0
    }
}

/// `Err(message)` unless `condition` holds.
pub fn check(condition: bool, message: &'static str) -> TestResult {
    if condition {
        Ok(())
    } else {
        Err(message)
    }
}
