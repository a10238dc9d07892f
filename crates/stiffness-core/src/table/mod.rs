//! Measurement tables as CSV: the one reader and the one writer of every file the workspace
//! reads or writes (VJM and CSJM measurements, pose tables, predictions, compensations).
//!
//! - [`CsvReader`]: the header on opening, then [`CsvReader::read`] parses the rows into the
//!   arrays a [`Layout`] asks for, a chunk at a time, on every core, with errors naming the line
//!   and the column; with [`CsvReader::open_hashing`] also the SHA-256 of the bytes read, in the
//!   same pass. Memory: the arrays plus two [`read::CHUNK_BYTES`] buffers.
//! - [`write_csv`]: row-major [`Column`] groups side by side, numbers in their shortest
//!   round-trip form, formatted on every core a bounded window at a time.
//!
//! Both give the same bytes / values whatever the thread count.
//!
//! Why not the `csv` crate: it parses a record at a time on one core (≈ 8 s/GB here); the
//! tables are numeric, one record per line, so lines can be split among threads safely.

pub mod error;
pub mod read;
pub mod write;

pub use error::TableError;
pub use read::{CellKind, CsvReader, Group, Layout, Table};
pub use write::{write_csv, Column};
