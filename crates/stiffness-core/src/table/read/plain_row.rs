//! The reader's one-pass path for a plain row: cells split and parsed together.
//!
//! Almost every row of a measurement file is plain: bare cells, no quotes, no spaces around a
//! cell, every number a finite decimal, every label one of its list. Such a row is read in one
//! pass: the number parser says where each number ends, so the comma after it is checked rather
//! than searched for, and no cell is sliced, trimmed or validated twice. Anything else — a quote,
//! padding, `inf`/`nan`, a number that std's parser would read differently or refuse, a label
//! outside its list, a field too many or too few — sends the row to the general path, which
//! reads it as before or names what is wrong, so the dialect and the errors do not depend on
//! which path ran.

use super::{CellKind, Cells, Plan};

/// Parses one line (without its line end) into row `row` of `values` if it is plain, and
/// returns whether it was. A plain row is ASCII outside its labels (which are text), so the
/// caller need not check it is UTF-8. A `false` may leave some of the row's cells written: the general
/// path writes every one of them again or fails.
pub(super) fn parse_plain_row(
    line: &[u8],
    plan: &Plan<'_>,
    values: &mut [Cells<'_>],
    row: usize,
) -> bool {
    let Some(last) = plan.width.checked_sub(1) else {
        return false;
    };
    let mut at = 0;
    for (k, slot) in plan.slots.iter().enumerate() {
        let rest = &line[at..];
        let used = match *slot {
            Some((g, offset)) => {
                let spec = &plan.groups[g];
                let index = row * spec.columns.len() + offset;
                let parsed = match (&mut values[g], spec.kind) {
                    (Cells::Float(v), _) => number(rest).map(|(x, n)| {
                        v[index] = x;
                        n
                    }),
                    (Cells::Integer(v), _) => {
                        let n = cell_len(rest);
                        integer(&rest[..n]).map(|x| {
                            v[index] = x;
                            n
                        })
                    }
                    (Cells::Label(v), CellKind::Label(allowed)) => {
                        let n = cell_len(rest);
                        let cell = &rest[..n];
                        allowed
                            .iter()
                            .position(|a| a.as_bytes().eq_ignore_ascii_case(cell))
                            .map(|i| {
                                v[index] = i as u8;
                                n
                            })
                    }
                    _ => unreachable!("a label group has label values"),
                };
                match parsed {
                    Some(n) => n,
                    None => return false,
                }
            }
            // A skipped cell is not read, but a quote in it may hide a comma, and it must be
            // text: a plain row is not checked as UTF-8 elsewhere.
            None => {
                let n = cell_len(rest);
                if !rest[..n].is_ascii() || memchr::memchr(b'"', &rest[..n]).is_some() {
                    return false;
                }
                n
            }
        };
        at += used;
        if k < last {
            if line.get(at) != Some(&b',') {
                return false;
            }
            at += 1;
        } else if at != line.len() {
            return false;
        }
    }
    true
}

fn cell_len(rest: &[u8]) -> usize {
    memchr::memchr(b',', rest).unwrap_or(rest.len())
}

/// A finite decimal at the start of `cell` and its length. Only cells that open like a number
/// (a digit, a sign or a point) are tried, and only a finite result is kept: `inf`, `nan` and
/// overflow take std's parser on the general path, which accepts the same decimal syntax and
/// rounds the same (both correctly rounded), so a value never depends on the path.
fn number(cell: &[u8]) -> Option<(f64, usize)> {
    match cell.first() {
        Some(b'0'..=b'9' | b'-' | b'+' | b'.') => {}
        _ => return None,
    }
    let (x, n) = fast_float2::parse_partial::<f64, _>(cell).ok()?;
    x.is_finite().then_some((x, n))
}

/// An integer cell, exactly as std reads it (no padding).
fn integer(cell: &[u8]) -> Option<i64> {
    std::str::from_utf8(cell).ok()?.parse().ok()
}
