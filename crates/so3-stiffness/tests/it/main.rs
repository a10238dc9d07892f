//! Integration tests of so3-stiffness.

mod bad_input;
mod csjm_diagnose;
mod csjm_diagnose_engine;
mod finite_differences;
mod identification;
mod kinetostatics;
mod robustness;
mod simulator;
mod so3;
mod stiffness;
mod strategies;
