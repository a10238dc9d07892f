//! Rust side of the "Python and Rust give identical results" check.
//!
//! `reference` computes results with the core crates directly (no pyo3, no numpy) on
//! deterministic inputs and compares them with `tests/data/reference.json`; the pytest suite
//! (`tests/test_reference.py`) feeds the same inputs through the Python API and compares with
//! the same file. Run with `UPDATE_REFERENCE=1` to rewrite the file after a deliberate change.
mod reference;
