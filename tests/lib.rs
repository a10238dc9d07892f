//! Cross-crate end-to-end tests live in `tests/tests/*.rs`; the diagnose study
//! (`src/bin/diagnose_study.rs`) keeps its machinery in [`study`].

#![deny(missing_docs)]

pub mod study;
