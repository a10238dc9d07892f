//! The one integration-test binary of `vjm`.

mod strategies;

mod bad_input;
mod bounded_input;
mod check_arrays;
mod compensation;
mod design;
mod full_model;
mod gear;
mod gear_backlash;
mod gear_compensate;
mod gear_diagnose;
mod gear_predict;
mod gravity;
mod identification;
mod identify_partial;
mod kinematics;
mod lsq;
mod model_robot_path;
mod model_vocabulary;
mod paper_study;
mod pinocchio;
mod planning;
mod prediction;
mod robustness;
mod screening;
mod stiffness_model;
mod urdf;

mod dataset;
mod diagnose;
mod output_tables;
mod outside;
mod testbed;
mod testbed_gravity;
mod truth_file;
