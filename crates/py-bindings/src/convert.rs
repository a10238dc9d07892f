//! numpy ⇄ Rust conversions: the only place where array layout, shape and dtype are handled.
//!
//! Inputs arrive as float64 numpy arrays (the Python layer converts other dtypes with
//! `numpy.asarray(x, dtype=float64)`). A C-contiguous array is borrowed without copying; any other
//! layout (Fortran order, strided views) is copied once into row-major order, which is the layout
//! every core crate expects (see `docs/conventions.md`). Shape errors name the argument and the
//! offending dimension.

use std::borrow::Cow;

use numpy::ndarray::{ArrayD, Ix1, Ix2, Ix3, IxDyn};
use numpy::{PyArrayDyn, PyArrayMethods, PyReadonlyArrayDyn, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyString};
use vjm::dataset::SetLabel;

use crate::errors::{shape_error, value_error};

/// A row-major view (borrowed when possible) of an `(N, cols…)` float64 array.
#[derive(Debug)]
pub struct Rows<'a> {
    /// Row-major data, `rows * row_len` values.
    pub data: Cow<'a, [f64]>,
    /// Number of rows N (the leading dimension).
    pub rows: usize,
}

/// Row-major data of `arr`: borrowed if C-contiguous and aligned, one copy otherwise.
pub fn row_major<'a>(arr: &'a PyReadonlyArrayDyn<'_, f64>) -> PyResult<Cow<'a, [f64]>> {
    // A float64 buffer at an address that is not a multiple of 8 (numpy allows it: arrays
    // rebuilt from pickle-5 or network buffers, `frombuffer` at an odd offset) cannot be read
    // as a Rust slice, or through ndarray: numpy copies it into a new, aligned array first.
    if !(arr.data() as usize).is_multiple_of(std::mem::align_of::<f64>()) {
        return Ok(Cow::Owned(numpy_copy(arr)?));
    }
    if arr.is_c_contiguous() {
        if let Ok(slice) = arr.as_slice() {
            return Ok(Cow::Borrowed(slice));
        }
    }
    if arr.is_fortran_contiguous() {
        if let Ok(slice) = arr.as_slice() {
            return Ok(Cow::Owned(fortran_to_row_major(slice, arr.shape())));
        }
    }
    // Any other strides: ndarray iterates in logical (row-major) order; fixed-dimension views
    // iterate much faster than the dynamic-dimension one.
    let view = arr.as_array();
    let owned: Vec<f64> = match view.ndim() {
        1 => view
            .into_dimensionality::<Ix1>()
            .map(|v| v.iter().copied().collect()),
        2 => view
            .into_dimensionality::<Ix2>()
            .map(|v| v.iter().copied().collect()),
        3 => view
            .into_dimensionality::<Ix3>()
            .map(|v| v.iter().copied().collect()),
        _ => Ok(view.iter().copied().collect()),
    }
    .unwrap_or_else(|_| arr.as_array().iter().copied().collect());
    Ok(Cow::Owned(owned))
}

/// Pose ids of an `(N,)` int64 array: borrowed if contiguous and aligned, one copy otherwise.
pub fn pose_ids<'a>(arr: &'a PyReadonlyArrayDyn<'_, i64>) -> PyResult<Cow<'a, [i64]>> {
    if arr.ndim() != 1 {
        return Err(shape_error(format!(
            "pose must be a one-dimensional array of N pose ids, got shape {:?}",
            arr.shape()
        )));
    }
    if (arr.data() as usize).is_multiple_of(std::mem::align_of::<i64>()) {
        if let Ok(slice) = arr.as_slice() {
            return Ok(Cow::Borrowed(slice));
        }
    }
    // Strided or unaligned (see `row_major`).
    numpy_copy(arr).map(Cow::Owned)
}

/// The values of a one-dimensional array of `rows` items (bool flags, int64 counts): borrowed
/// if contiguous and aligned, one copy otherwise; the error names `name` and the shape.
pub fn column<'a, T: numpy::Element + Copy>(
    arr: &'a PyReadonlyArrayDyn<'_, T>,
    name: &str,
    rows: usize,
) -> PyResult<Cow<'a, [T]>> {
    if arr.shape() != [rows] {
        return Err(shape_error(format!(
            "{name} must have shape ({rows},), got {:?}",
            arr.shape()
        )));
    }
    if (arr.data() as usize).is_multiple_of(std::mem::align_of::<T>()) {
        if let Ok(slice) = arr.as_slice() {
            return Ok(Cow::Borrowed(slice));
        }
    }
    numpy_copy(arr).map(Cow::Owned)
}

/// The values of `arr` in C order, copied by numpy into a new (aligned, contiguous) array first:
/// the one way to read an unaligned buffer without `unsafe`.
fn numpy_copy<T: numpy::Element + Copy>(arr: &PyReadonlyArrayDyn<'_, T>) -> PyResult<Vec<T>> {
    let copy = arr
        .as_any()
        .call_method1("copy", ("C",))?
        .cast_into::<PyArrayDyn<T>>()
        .map_err(PyErr::from)?;
    let copy = copy.readonly();
    let slice = copy.as_slice().map_err(|e| {
        crate::errors::internal_error(format!("numpy's C-ordered copy is not contiguous: {e}"))
    })?;
    Ok(slice.to_vec())
}

/// The train/test labels of a sequence of strings (`"train"`/`"test"`, any case, spaces
/// trimmed), read one item at a time: no list of Rust strings is built beside the caller's.
pub fn set_labels(seq: &Bound<'_, PyAny>) -> PyResult<Vec<SetLabel>> {
    if seq.is_instance_of::<PyString>() {
        return Err(value_error(
            "set must be a sequence with one \"train\" or \"test\" label per row, not one string",
        ));
    }
    let mut labels = Vec::with_capacity(seq.len().unwrap_or(0));
    for (i, item) in seq.try_iter()?.enumerate() {
        let item = item?;
        let text = item.cast::<PyString>().map_err(|_| {
            value_error(format!(
                "set[{i}] must be the string \"train\" or \"test\", got {}",
                item.get_type()
                    .name()
                    .map(|n| n.to_string())
                    .unwrap_or_default()
            ))
        })?;
        let text = text.to_cow()?;
        let label = text.trim();
        labels.push(if label.eq_ignore_ascii_case("train") {
            SetLabel::Train
        } else if label.eq_ignore_ascii_case("test") {
            SetLabel::Test
        } else {
            return Err(value_error(format!(
                "set[{i}] = `{}`: expected \"train\" or \"test\"",
                label.to_ascii_lowercase()
            )));
        });
    }
    Ok(labels)
}

/// Reorders a Fortran-ordered buffer of `shape` into row-major order.
///
/// A dedicated loop rather than ndarray's dynamic-dimension iterator, which costs tens of ns per
/// element (an N = 1e6 identification would spend most of its time here): the leading axis N
/// is contiguous in the source, and the trailing item (n, 6, 3×3…) is small, so each trailing
/// position is one contiguous read stream.
pub fn fortran_to_row_major(src: &[f64], shape: &[usize]) -> Vec<f64> {
    let rows = shape.first().copied().unwrap_or(1);
    let item: usize = shape.iter().skip(1).product();
    let mut out = vec![0.0; src.len()];
    if rows == 0 || item == 0 {
        return out;
    }
    let trailing = &shape[1..];
    // Fortran offset (in units of `rows`) of every trailing position, in row-major order.
    let f_off: Vec<usize> = (0..item)
        .map(|c| {
            let mut rest = c;
            let mut digits = vec![0usize; trailing.len()];
            for (k, &d) in trailing.iter().enumerate().rev() {
                digits[k] = rest % d;
                rest /= d;
            }
            let mut off = 0usize;
            let mut stride = 1usize;
            for (k, &d) in trailing.iter().enumerate() {
                off += digits[k] * stride;
                stride *= d;
            }
            off
        })
        .collect();
    // Blocks of rows small enough that the output block stays in cache while the `item`
    // source streams are read sequentially.
    const BLOCK: usize = 256;
    let mut start = 0;
    while start < rows {
        let end = (start + BLOCK).min(rows);
        let out_block = &mut out[start * item..end * item];
        for (c, &off) in f_off.iter().enumerate() {
            let column = &src[rows * off + start..rows * off + end];
            for (i, v) in column.iter().enumerate() {
                out_block[i * item + c] = *v;
            }
        }
        start = end;
    }
    out
}

/// Describes a shape for messages: `(N, 6)`, `(N, 3, 3)`.
fn describe(trailing: &[usize]) -> String {
    let mut s = String::from("(N");
    for d in trailing {
        s.push_str(&format!(", {d}"));
    }
    s.push(')');
    s
}

/// Checks that `arr` has shape `(N, trailing…)` and returns its rows in row-major order.
///
/// `name` is the argument's user-facing name; the error names the offending dimension.
pub fn batch<'a>(
    arr: &'a PyReadonlyArrayDyn<'_, f64>,
    name: &str,
    trailing: &[usize],
) -> PyResult<Rows<'a>> {
    let shape = arr.shape();
    let expected = describe(trailing);
    if shape.len() != trailing.len() + 1 {
        return Err(shape_error(format!(
            "{name} must have shape {expected}, got {} dimension(s) with shape {shape:?}",
            shape.len()
        )));
    }
    for (k, (&got, &want)) in shape[1..].iter().zip(trailing).enumerate() {
        if got != want {
            return Err(shape_error(format!(
                "{name} must have shape {expected}: dimension {} has size {got}, expected {want} (shape {shape:?})",
                k + 1
            )));
        }
    }
    Ok(Rows {
        data: row_major(arr)?,
        rows: shape[0],
    })
}

/// Checks that `arr` has exactly the shape `expected` and returns it in row-major order.
pub fn fixed<'a>(
    arr: &'a PyReadonlyArrayDyn<'_, f64>,
    name: &str,
    expected: &[usize],
) -> PyResult<Cow<'a, [f64]>> {
    let shape = arr.shape();
    if shape != expected {
        let which = if shape.len() != expected.len() {
            format!("{} dimension(s) instead of {}", shape.len(), expected.len())
        } else {
            let k = shape
                .iter()
                .zip(expected)
                .position(|(a, b)| a != b)
                .unwrap_or(0);
            format!(
                "dimension {k} has size {}, expected {}",
                shape[k], expected[k]
            )
        };
        return Err(shape_error(format!(
            "{name} must have shape {expected:?}, got {shape:?}: {which}"
        )));
    }
    row_major(arr)
}

/// Accepts either one item of shape `item` or a batch `(N, item…)`.
///
/// Returns the row-major data, N (1 for a single item) and whether the input was batched, so
/// that the result can be given the same leading shape.
pub fn single_or_batch<'a>(
    arr: &'a PyReadonlyArrayDyn<'_, f64>,
    name: &str,
    item: &[usize],
) -> PyResult<(Cow<'a, [f64]>, usize, bool)> {
    if arr.shape() == item {
        return Ok((row_major(arr)?, 1, false));
    }
    let shape = arr.shape();
    if shape.len() == item.len() + 1 && &shape[1..] == item {
        return Ok((row_major(arr)?, shape[0], true));
    }
    let single = format!(
        "({}{})",
        item.iter()
            .map(|d| d.to_string())
            .collect::<Vec<_>>()
            .join(", "),
        if item.len() == 1 { "," } else { "" }
    );
    let detail = if shape.len() == item.len() + 1 {
        let k = shape[1..]
            .iter()
            .zip(item)
            .position(|(a, b)| a != b)
            .unwrap_or(0)
            + 1;
        format!(
            "dimension {k} has size {}, expected {}",
            shape[k],
            item[k - 1]
        )
    } else if shape.len() == item.len() {
        let k = shape
            .iter()
            .zip(item)
            .position(|(a, b)| a != b)
            .unwrap_or(0);
        format!("dimension {k} has size {}, expected {}", shape[k], item[k])
    } else {
        format!("it has {} dimension(s)", shape.len())
    };
    Err(shape_error(format!(
        "{name} must have shape {single} or {}, got {shape:?}: {detail}",
        describe(item)
    )))
}

/// Refuses a key of effect dict `effects[i]` (named `name`) that is not `effect` or one of
/// `valid`: a typo would otherwise be silently ignored. Shared by the VJM and CSJM testbeds.
pub fn check_effect_keys(
    d: &Bound<'_, PyDict>,
    i: usize,
    name: &str,
    valid: &[&str],
) -> PyResult<()> {
    for key in d.keys() {
        let key: String = key
            .extract()
            .map_err(|_| value_error(format!("effects[{i}] ({name}): keys must be strings")))?;
        if key != "effect" && !valid.contains(&key.as_str()) {
            let listed = if valid.is_empty() {
                "none besides `effect`".to_string()
            } else {
                valid.join(", ")
            };
            return Err(value_error(format!(
                "effects[{i}] ({name}): unknown key `{key}` (valid keys: {listed})"
            )));
        }
    }
    Ok(())
}

/// Checks that every value is finite; the error names the argument and the index of the first
/// offending entry (row-major `shape`).
pub fn check_finite(data: &[f64], name: &str, shape: &[usize]) -> PyResult<()> {
    if let Some(flat) = data.iter().position(|v| !v.is_finite()) {
        let mut index = vec![0usize; shape.len()];
        let mut rest = flat;
        for (k, &d) in shape.iter().enumerate().rev() {
            if d > 0 {
                index[k] = rest % d;
                rest /= d;
            }
        }
        return Err(crate::errors::value_error(format!(
            "{name} contains a non-finite value ({}) at index {index:?}",
            data[flat]
        )));
    }
    Ok(())
}

/// A new numpy array of shape `shape` owning `data` (row-major), without copying.
pub fn to_numpy<'py>(
    py: Python<'py>,
    data: Vec<f64>,
    shape: &[usize],
) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
    let arr = ArrayD::from_shape_vec(IxDyn(shape), data).map_err(|e| {
        crate::errors::internal_error(format!("result of shape {shape:?} is inconsistent: {e}"))
    })?;
    Ok(PyArrayDyn::from_owned_array(py, arr))
}

/// [`to_numpy`] as an owned Python object: a field of a typed result class.
pub fn numpy_field(py: Python<'_>, data: Vec<f64>, shape: &[usize]) -> PyResult<Py<PyAny>> {
    Ok(to_numpy(py, data, shape)?.into_any().unbind())
}

/// A new numpy bool array of shape `shape` owning `data`.
pub fn to_numpy_bool<'py>(
    py: Python<'py>,
    data: Vec<bool>,
    shape: &[usize],
) -> PyResult<Bound<'py, PyArrayDyn<bool>>> {
    let arr = ArrayD::from_shape_vec(IxDyn(shape), data).map_err(|e| {
        crate::errors::internal_error(format!("result of shape {shape:?} is inconsistent: {e}"))
    })?;
    Ok(PyArrayDyn::from_owned_array(py, arr))
}

#[cfg(test)]
mod tests {
    use super::fortran_to_row_major;

    #[test]
    fn fortran_reordering_matches_the_index_formula() {
        // shape (4, 2, 3): Fortran offset of (i, j, k) is i + 4 (j + 2 k).
        let shape = [4usize, 2, 3];
        let src: Vec<f64> = (0..24).map(f64::from).collect();
        let out = fortran_to_row_major(&src, &shape);
        for i in 0..4 {
            for j in 0..2 {
                for k in 0..3 {
                    assert_eq!(out[(i * 2 + j) * 3 + k], src[i + 4 * (j + 2 * k)]);
                }
            }
        }
    }
}
