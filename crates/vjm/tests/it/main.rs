//! The one integration-test binary of `vjm`.

mod strategies;

mod bad_input;
mod design;
mod identification;
mod kinematics;
mod lsq;
mod pinocchio;
mod prediction;
mod urdf;

mod dataset;
mod diagnose;
mod outside;
mod testbed;
