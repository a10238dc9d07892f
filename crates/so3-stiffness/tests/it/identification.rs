//! Tests of `so3_stiffness::identification` (issue 4): measurement file, pose and load
//! measurement, the fit, verification, the seed's Tables 3–4 and the virtual campaign.

mod campaign;
mod common;
mod dataset;
mod fit;
mod pose_load;
mod seed_tables;
mod verify;
