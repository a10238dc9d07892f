//! Numbers in messages: a user's value echoed short.
//!
//! Rust's `{}` for `f64` never uses an exponent, so `1e308` prints as 309 digits and `1e-300`
//! as 300 zeros. [`Short`] prints the shortest text that reads back as the same value (so
//! nothing is lost), with an exponent outside `[1e-4, 1e6)`: `1e308`, `-2.5e-7`, `0.125`,
//! `12345.5`, `inf`, `NaN`. Every message that quotes a number uses it.

use std::fmt;

/// Formats an `f64` shortly for a message (see the [module documentation](self)).
///
/// ```
/// use stiffness_core::num::Short;
/// assert_eq!(Short(1e308).to_string(), "1e308");
/// assert_eq!(Short(-2.5e-7).to_string(), "-2.5e-7");
/// assert_eq!(Short(0.125).to_string(), "0.125");
/// assert_eq!(Short(3.0).to_string(), "3");
/// assert_eq!(Short(f64::NEG_INFINITY).to_string(), "-inf");
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Short(pub f64);

impl fmt::Display for Short {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let x = self.0;
        let a = x.abs();
        if !x.is_finite() || x == 0.0 || (1e-4..1e6).contains(&a) {
            // Shortest round-trip positional form (`inf`, `NaN`, `0`, `-0`, `0.001`).
            write!(f, "{x}")
        } else {
            // Shortest round-trip digits with an exponent (`1e308`, `1.5e-7`).
            write!(f, "{x:e}")
        }
    }
}

/// `[a, b, c]` with every value [`Short`].
///
/// ```
/// use stiffness_core::num::short_list;
/// assert_eq!(short_list(&[0.0, 1e300, -0.5]), "[0, 1e300, -0.5]");
/// ```
pub fn short_list(values: &[f64]) -> String {
    let items: Vec<String> = values.iter().map(|v| Short(*v).to_string()).collect();
    format!("[{}]", items.join(", "))
}
