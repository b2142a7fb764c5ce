//! One call from a scenario to a finished run: build the world and the stored map, set up
//! the estimator, drive, and return the [`RunLog`]. What the CLI, the demo and the
//! integration tests call.

use std::fmt;

use crate::closed_loop::{self, OdometryOnly, RunLog, RunOptions};
use crate::estimator::LocCoreEstimator;
use crate::scenario::{Scenario, ScenarioError};
use crate::stored_map;

/// Which estimator a run tests.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum EstimatorChoice {
    /// loc-core's localiser (the product).
    #[default]
    Localizer,
    /// Odometry alone (the baseline).
    OdometryOnly,
}

/// Why a run could not start.
#[derive(Debug)]
pub enum SimError {
    /// The scenario is wrong.
    Scenario(ScenarioError),
    /// The design does not fit loc-core's stored map.
    Map(loc_core::map::MapError),
}

impl fmt::Display for SimError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SimError::Scenario(e) => write!(f, "{e}"),
            SimError::Map(e) => write!(
                f,
                "the tunnel's design does not fit loc-core's stored map: {e} (shorten the tunnel or widen the landmark spacing)"
            ),
        }
    }
}

impl std::error::Error for SimError {}

impl From<ScenarioError> for SimError {
    fn from(e: ScenarioError) -> Self {
        SimError::Scenario(e)
    }
}

/// Runs `scenario` with the chosen estimator.
pub fn run_scenario(
    scenario: &Scenario,
    estimator: EstimatorChoice,
    options: &RunOptions<'_>,
) -> Result<RunLog, SimError> {
    scenario.validate()?;
    let world = scenario.build_world()?;
    match estimator {
        EstimatorChoice::OdometryOnly => Ok(closed_loop::run(
            scenario,
            &world,
            &mut OdometryOnly::default(),
            options,
        )),
        EstimatorChoice::Localizer => {
            let choice = scenario.landmark_choice()?;
            // The localiser borrows the map: both live for this call only.
            let map = stored_map::build(&world, &choice).map_err(SimError::Map)?;
            let mut est = LocCoreEstimator::new(&map, scenario);
            Ok(closed_loop::run(scenario, &world, &mut est, options))
        }
    }
}

/// Runs `scenario` with loc-core's localiser against `map` instead of the map built from the
/// design (a surveyed map, `host-sim survey`'s; or any loc-core map file): the simulated
/// tunnel stays the scenario's, so the metrics say how well the vehicle localises in the
/// true tunnel with that map.
pub fn run_scenario_with_map(
    scenario: &Scenario,
    map: &loc_core::map::TunnelMap,
    options: &RunOptions<'_>,
) -> Result<RunLog, SimError> {
    scenario.validate()?;
    let world = scenario.build_world()?;
    let mut est = LocCoreEstimator::new(map, scenario);
    Ok(closed_loop::run(scenario, &world, &mut est, options))
}

/// Odometry alone over `scenario` with default options (tests of the outputs and reports).
#[cfg(test)]
pub(crate) fn odometry_run(scenario: &Scenario) -> RunLog {
    match run_scenario(
        scenario,
        EstimatorChoice::OdometryOnly,
        &RunOptions::default(),
    ) {
        Ok(log) => log,
        Err(e) => panic!("{e}"),
    }
}

/// Runs `scenario` like [`run_scenario`] and also returns the CPU time of the whole run
/// (world, map, vehicle, lidar and estimator on this thread), seconds: the figure for
/// "faster than real time on one core", unaffected by other load on the machine.
pub fn run_scenario_timed(
    scenario: &Scenario,
    estimator: EstimatorChoice,
    options: &RunOptions<'_>,
) -> Result<(RunLog, f64), SimError> {
    let t0 = cpu_time::ThreadTime::now();
    let log = run_scenario(scenario, estimator, options)?;
    Ok((log, t0.elapsed().as_secs_f64()))
}
