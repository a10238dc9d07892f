//! Shared seeded data generators for the criterion benches (see `benches/*.rs`).
