//! numpy arrays in and out.
//!
//! In: anything `numpy.asarray` accepts (arrays of any real dtype, lists, tuples), converted
//! to float64 (or the integer type named) and checked for its shape; a wrong shape or a value
//! that does not convert is a `ValueError`/`TypeError` naming the argument. Out: every array
//! is a new numpy array that owns a snapshot of the simulation's state (the snapshot is made
//! once, by the Rust `state()`, and handed to numpy without a second copy); writing to it
//! does not change the simulation.

use numpy::{IntoPyArray, PyArray1, PyArray2, PyArrayMethods, PyUntypedArrayMethods};
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;

/// `numpy.ascontiguousarray(obj, dtype)`, with a `TypeError` naming `name` when it fails.
fn as_array<'py>(obj: &Bound<'py, PyAny>, name: &str, dtype: &str) -> PyResult<Bound<'py, PyAny>> {
    let np = obj.py().import("numpy")?;
    np.call_method1("ascontiguousarray", (obj, dtype))
        .map_err(|e| {
            PyTypeError::new_err(format!("{name}: cannot convert to a {dtype} array ({e})"))
        })
}

/// An `(n, D)` float64 array as `n` rows of `D` values.
pub(crate) fn rows<const D: usize>(obj: &Bound<'_, PyAny>, name: &str) -> PyResult<Vec<[f64; D]>> {
    let a = as_array(obj, name, "float64")?;
    let a = a.cast::<PyArray2<f64>>().map_err(|_| {
        PyValueError::new_err(format!(
            "{name}: must be a 2-D array of shape (n, {D}), got {} dimension(s)",
            ndim(obj)
        ))
    })?;
    let shape = a.shape();
    if shape[1] != D {
        return Err(PyValueError::new_err(format!(
            "{name}: must have shape (n, {D}), got ({}, {})",
            shape[0], shape[1]
        )));
    }
    let ro = a.readonly();
    let flat = ro.as_slice()?;
    Ok(flat
        .chunks_exact(D)
        .map(|c| std::array::from_fn(|k| c[k]))
        .collect())
}

/// Positions or velocities of 2 or 3 components as 3-vectors (`z = 0` for 2 components).
pub(crate) fn vectors(obj: &Bound<'_, PyAny>, name: &str, dim: usize) -> PyResult<Vec<[f64; 3]>> {
    match dim {
        2 => Ok(rows::<2>(obj, name)?
            .into_iter()
            .map(|[x, y]| [x, y, 0.0])
            .collect()),
        3 => rows::<3>(obj, name),
        d => Err(PyValueError::new_err(format!("dim: {d} (use 2 or 3)"))),
    }
}

/// A 1-D float64 array of length `n` (or any length when `n` is `None`).
pub(crate) fn values(obj: &Bound<'_, PyAny>, name: &str, n: Option<usize>) -> PyResult<Vec<f64>> {
    one_d::<f64>(obj, name, n, "float64")
}

/// A 1-D array of non-negative integers (converted to `u32`) of length `n`.
pub(crate) fn indices(obj: &Bound<'_, PyAny>, name: &str, n: Option<usize>) -> PyResult<Vec<u32>> {
    let v = one_d::<i64>(obj, name, n, "int64")?;
    v.iter()
        .enumerate()
        .map(|(i, &x)| {
            u32::try_from(x).map_err(|_| {
                PyValueError::new_err(format!("{name}[{i}]: {x} (must be in 0..=4294967295)"))
            })
        })
        .collect()
}

fn one_d<T: numpy::Element + Copy>(
    obj: &Bound<'_, PyAny>,
    name: &str,
    n: Option<usize>,
    dtype: &str,
) -> PyResult<Vec<T>> {
    let a = as_array(obj, name, dtype)?;
    let a = a.cast::<PyArray1<T>>().map_err(|_| {
        PyValueError::new_err(format!(
            "{name}: must be a 1-D array, got {} dimension(s)",
            ndim(obj)
        ))
    })?;
    let len = a.len();
    if let Some(n) = n.filter(|&n| n != len) {
        return Err(PyValueError::new_err(format!(
            "{name}: length {len}, must be {n}"
        )));
    }
    Ok(a.readonly().as_slice()?.to_vec())
}

fn ndim(obj: &Bound<'_, PyAny>) -> usize {
    obj.getattr("ndim")
        .and_then(|d| d.extract::<usize>())
        .unwrap_or(0)
}

/// `n` rows of `D` values as an `(n, D)` array (no copy of the flattened rows).
pub(crate) fn to_rows<'py, const D: usize, T: numpy::Element + Copy>(
    py: Python<'py>,
    rows: &[[T; D]],
) -> PyResult<Bound<'py, PyArray2<T>>> {
    let flat: Vec<T> = rows.iter().flatten().copied().collect();
    flat.into_pyarray(py).reshape([rows.len(), D])
}

/// 3-vectors as an `(n, dim)` array (the first `dim` components).
pub(crate) fn to_vectors<'py>(
    py: Python<'py>,
    v: &[[f64; 3]],
    dim: usize,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let flat: Vec<f64> = v.iter().flat_map(|x| x[..dim].iter().copied()).collect();
    flat.into_pyarray(py).reshape([v.len(), dim])
}

/// A vector as a 1-D array (moved, not copied).
pub(crate) fn to_array<'py, T: numpy::Element>(
    py: Python<'py>,
    v: Vec<T>,
) -> Bound<'py, PyArray1<T>> {
    v.into_pyarray(py)
}

/// A `[x, y, z]` box corner or length from a sequence of `dim` numbers.
pub(crate) fn corner(obj: &Bound<'_, PyAny>, name: &str, dim: usize) -> PyResult<[f64; 3]> {
    let v = values(obj, name, Some(dim))?;
    let mut out = [0.0; 3];
    out[..dim].copy_from_slice(&v);
    Ok(out)
}

/// `dim` flags (one bool for every axis, or a sequence of `dim` bools) as `[bool; 3]`.
pub(crate) fn flags(obj: &Bound<'_, PyAny>, name: &str, dim: usize) -> PyResult<[bool; 3]> {
    if let Ok(b) = obj.extract::<bool>() {
        return Ok([b; 3]);
    }
    let v: Vec<bool> = obj.extract().map_err(|_| {
        PyTypeError::new_err(format!("{name}: a bool or a sequence of {dim} bools"))
    })?;
    if v.len() != dim {
        return Err(PyValueError::new_err(format!(
            "{name}: {} values, must be {dim} (one per axis)",
            v.len()
        )));
    }
    let mut out = [false; 3];
    out[..dim].copy_from_slice(&v);
    Ok(out)
}

/// The number of columns of a 2-D array argument: 2 or 3 (the dimension of the points).
pub(crate) fn columns(obj: &Bound<'_, PyAny>, name: &str) -> PyResult<usize> {
    let shape: Vec<usize> = obj
        .getattr("shape")
        .and_then(|s| s.extract())
        .or_else(|_| as_array(obj, name, "float64")?.getattr("shape")?.extract())?;
    match shape.as_slice() {
        [_, d @ (2 | 3)] => Ok(*d),
        other => Err(PyValueError::new_err(format!(
            "{name}: must have shape (n, 2) or (n, 3), got {other:?}"
        ))),
    }
}

/// An `(s, s)` float64 array, flattened row by row.
pub(crate) fn rows_dyn(obj: &Bound<'_, PyAny>, name: &str, s: usize) -> PyResult<Vec<f64>> {
    let a = as_array(obj, name, "float64")?;
    let a = a.cast::<PyArray2<f64>>().map_err(|_| {
        PyValueError::new_err(format!(
            "{name}: must be a number or a 2-D array of shape ({s}, {s})"
        ))
    })?;
    if a.shape() != [s, s] {
        return Err(PyValueError::new_err(format!(
            "{name}: shape {:?}, must be ({s}, {s}) (one value per species pair)",
            a.shape()
        )));
    }
    Ok(a.readonly().as_slice()?.to_vec())
}
