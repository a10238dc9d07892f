//! SO(3) Lie-group toolkit and the stiffness model of a cable-driven spherical joint module.
#![deny(missing_docs)]
