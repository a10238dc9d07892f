//! Integration tests of `stiffness-core`.

mod cancel;
