//! Integration tests of `stiffness-core`.

mod cancel;
mod decompose;
mod engine;
mod table;
mod weak;
mod wild_cluster;
