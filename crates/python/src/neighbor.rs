//! `simkit.NeighborSearch`: all pairs of points closer than a cutoff, in 2D or 3D.

use numpy::{PyArray1, PyArray2};
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use simkit::backend::Result;
use simkit::neighbor::{
    BruteForce, CellGrid, LinkedCells, ListKind, NeighborSearch as Search, SortedCells, VerletList,
};

use crate::arrays;
use crate::common::Owned;
use crate::errors::IntoPy;

/// One search method in `D` dimensions. (The variants differ in size; one lives in each
/// Python object and is never moved after construction, so none is boxed.)
#[allow(clippy::large_enum_variant)]
enum Method<const D: usize> {
    Sorted(SortedCells<D>),
    Linked(LinkedCells<D>),
    Brute(BruteForce<D>),
    Verlet(VerletList<D>),
    #[cfg(feature = "gpu")]
    Gpu(simkit::neighbor::GpuNeighborSearch<D>),
}

/// Runs `$body` with `$s` bound to the search, whatever its method.
macro_rules! with_method {
    ($m:expr, $s:ident => $body:expr) => {
        match $m {
            Method::Sorted($s) => $body,
            Method::Linked($s) => $body,
            Method::Brute($s) => $body,
            Method::Verlet($s) => $body,
            #[cfg(feature = "gpu")]
            Method::Gpu($s) => $body,
        }
    };
}

impl<const D: usize> Method<D> {
    fn new(grid: &CellGrid<D>, method: &str, skin: f64) -> PyResult<Self> {
        Ok(match method {
            "sorted" => Method::Sorted(SortedCells::new(grid)),
            "linked" => Method::Linked(LinkedCells::new(grid)),
            "brute" => Method::Brute(BruteForce::new(grid)),
            "verlet" => Method::Verlet(VerletList::new(grid, skin, ListKind::Half).py()?),
            #[cfg(feature = "gpu")]
            "gpu" => Method::Gpu(
                simkit::neighbor::GpuNeighborSearch::new(crate::backend::gpu_context()?, grid)
                    .py()?,
            ),
            other => {
                return Err(PyValueError::new_err(format!(
                    "invalid method: {other:?} (use 'sorted', 'linked', 'verlet', 'brute' or \
                     'gpu')"
                )));
            }
        })
    }

    fn build(&mut self, points: &[[f64; D]]) -> Result<()> {
        with_method!(self, s => s.build(points))
    }

    /// Every pair `(i, j)` with `i < j` and its distance, sorted by `(i, j)`.
    fn pairs(&mut self) -> Result<(Vec<[u32; 2]>, Vec<f64>)> {
        let mut found: Vec<([u32; 2], f64)> = Vec::new();
        with_method!(self, s => s.for_each_pair(|i, j, _, r2| {
            let (a, b) = if i < j { (i, j) } else { (j, i) };
            found.push(([a as u32, b as u32], r2.sqrt()));
        }))?;
        found.sort_unstable_by_key(|p| p.0);
        Ok(found.into_iter().unzip())
    }

    fn counts(&mut self) -> Result<Vec<u32>> {
        with_method!(self, s => s.neighbor_counts())
    }

    fn pair_count(&mut self) -> Result<usize> {
        with_method!(self, s => s.pair_count())
    }

    fn name(&self) -> String {
        with_method!(self, s => s.name())
    }
}

/// Pairs `(m, 2)` and their distances `(m,)`.
type Pairs<'py> = (Bound<'py, PyArray2<u32>>, Bound<'py, PyArray1<f64>>);

/// The search in 2D or 3D.
enum AnyDim {
    Two(Method<2>),
    Three(Method<3>),
}

/// Runs `$body` with `$m` bound to the method, whatever the dimension.
macro_rules! with_dim {
    ($d:expr, $m:ident => $body:expr) => {
        match $d {
            AnyDim::Two($m) => $body,
            AnyDim::Three($m) => $body,
        }
    };
}

/// All pairs of points closer than `cutoff` in the box `[box_lo, box_hi)` (2 or 3 values
/// each: the dimension), periodic along the axes named by `periodic` (a bool for all, or
/// one per axis).
///
/// `method`: `"sorted"` (cells sorted by index, half-shell stencil: the fastest on a CPU),
/// `"linked"` (linked cells), `"verlet"` (a Verlet list with `skin`), `"brute"` (every pair,
/// for checks) or `"gpu"` (the GPU cell list). Call `build(points)` with an `(n, D)` array,
/// then `pairs()`, `pair_count()` or `neighbor_counts()`.
#[pyclass(module = "simkit")]
pub(crate) struct NeighborSearch {
    inner: Owned<AnyDim>,
    dim: usize,
    built: bool,
}

impl NeighborSearch {
    fn require_built(&self) -> PyResult<()> {
        if self.built {
            Ok(())
        } else {
            Err(PyRuntimeError::new_err(
                "no points yet: call build(points) first",
            ))
        }
    }
}

#[pymethods]
impl NeighborSearch {
    #[new]
    #[pyo3(signature = (box_lo, box_hi, cutoff, *, periodic=None, method="sorted", skin=0.3))]
    fn new(
        box_lo: &Bound<'_, PyAny>,
        box_hi: &Bound<'_, PyAny>,
        cutoff: f64,
        periodic: Option<&Bound<'_, PyAny>>,
        method: &str,
        skin: f64,
    ) -> PyResult<Self> {
        let lo = arrays::values(box_lo, "box_lo", None)?;
        let dim = lo.len();
        if dim != 2 && dim != 3 {
            return Err(PyValueError::new_err(format!(
                "box_lo: {dim} values, must be 2 or 3 (the dimension)"
            )));
        }
        let hi = arrays::values(box_hi, "box_hi", Some(dim))?;
        let periodic = match periodic {
            Some(p) => arrays::flags(p, "periodic", dim)?,
            None => [true; 3],
        };
        let len: Vec<f64> = hi.iter().zip(&lo).map(|(h, l)| h - l).collect();
        let inner = if dim == 2 {
            let grid = CellGrid::new(
                [lo[0], lo[1]],
                [len[0], len[1]],
                [periodic[0], periodic[1]],
                cutoff,
            )
            .py()?;
            AnyDim::Two(Method::new(&grid, method, skin)?)
        } else {
            let grid = CellGrid::new(
                [lo[0], lo[1], lo[2]],
                [len[0], len[1], len[2]],
                periodic,
                cutoff,
            )
            .py()?;
            AnyDim::Three(Method::new(&grid, method, skin)?)
        };
        Ok(Self {
            inner: Owned::new(inner),
            dim,
            built: false,
        })
    }

    /// (Re)builds the search from `points`, shape `(n, D)` (the GIL is released meanwhile).
    /// Points outside a non-periodic side of the box, or not finite, are a `ValueError`.
    fn build(&mut self, py: Python<'_>, points: &Bound<'_, PyAny>) -> PyResult<()> {
        self.built = false;
        match self.inner.get() {
            AnyDim::Two(m) => {
                let p = arrays::rows::<2>(points, "points")?;
                py.detach(|| m.build(&p)).py()?;
            }
            AnyDim::Three(m) => {
                let p = arrays::rows::<3>(points, "points")?;
                py.detach(|| m.build(&p)).py()?;
            }
        }
        self.built = true;
        Ok(())
    }

    /// Every pair closer than the cutoff: `(pairs, distances)`, `pairs` a uint32 array of
    /// shape `(m, 2)` with `i < j` in each row, sorted by `(i, j)`, and `distances` (minimum
    /// image) of shape `(m,)`.
    fn pairs<'py>(&mut self, py: Python<'py>) -> PyResult<Pairs<'py>> {
        self.require_built()?;
        let (p, d) = with_dim!(self.inner.get(), m => py.detach(|| m.pairs())).py()?;
        Ok((arrays::to_rows(py, &p)?, arrays::to_array(py, d)))
    }

    /// The number of pairs closer than the cutoff.
    fn pair_count(&mut self, py: Python<'_>) -> PyResult<usize> {
        self.require_built()?;
        with_dim!(self.inner.get(), m => py.detach(|| m.pair_count())).py()
    }

    /// The number of neighbours of every point, uint32, shape `(n,)`.
    fn neighbor_counts<'py>(&mut self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<u32>>> {
        self.require_built()?;
        let c = with_dim!(self.inner.get(), m => py.detach(|| m.counts())).py()?;
        Ok(arrays::to_array(py, c))
    }

    /// 2 or 3.
    #[getter]
    fn dim(&self) -> usize {
        self.dim
    }

    /// The method's name.
    #[getter]
    fn method(&mut self) -> String {
        with_dim!(self.inner.get(), m => m.name())
    }

    fn __repr__(&mut self) -> String {
        let method = self.method();
        format!("NeighborSearch({}D, {method})", self.dim)
    }
}
