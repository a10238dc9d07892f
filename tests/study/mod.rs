//! The diagnose study (issues 11/12's yardstick): false-alarm rate of `vjm::diagnose` on clean
//! campaigns of several robots and instrument noise levels, with and without the noise level
//! given; detection rate of catalogue effects, of effects outside the catalogue and of two
//! effects at once; the CSJM diagnose's false-alarm rate. Run by
//! `cargo run --release -p robot-stiffness-tests --bin diagnose_study`; results and the exact
//! command in docs/diagnose-study.md.

pub mod effects;
pub mod report;
pub mod robots;
pub mod run;
pub mod stats;
