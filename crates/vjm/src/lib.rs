//! Virtual joint method (VJM) stiffness models of serial robots.
#![deny(missing_docs)]
