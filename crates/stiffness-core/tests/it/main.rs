//! Integration tests of `stiffness-core`.

mod cancel;
mod decompose;
mod engine;
mod scaled_svd;
mod table;
mod weak;
mod wild_cluster;
