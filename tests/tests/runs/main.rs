//! Runs: the host runner end to end, stopping, capacities, passivity, faulty input, the
//! watchdog and the firmware's release rule; one test binary, a module per file.

mod capacity;
mod chip_scenarios;
mod faults_input;
mod faults_watchdog;
mod passivity;
mod release_rule;
mod runner;
mod stopping;
