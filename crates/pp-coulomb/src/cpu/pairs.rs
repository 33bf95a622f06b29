//! What a block kernel takes: the sources in structure-of-arrays form, which law it applies
//! and how it forms the separations. Both the portable kernel and the AVX-512 kernel import
//! this module.

/// Sources in structure-of-arrays form, padded to a multiple of the kernel's lane count.
pub(crate) struct Sources<'a, T> {
    pub x: &'a [T],
    pub y: &'a [T],
    pub z: &'a [T],
    pub q: &'a [T],
    /// The low parts of the coordinates when they are split into `x + lo` (the mixed
    /// mode's f32 kernel: `x` is the f64 coordinate rounded to f32, `lo` the f32 rounding of
    /// the remainder), as long as `x`; `None` for plain coordinates.
    pub lo: Option<[&'a [T]; 3]>,
}

/// Which pair law a kernel applies (a compile-time constant in the SIMD path).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum LawKind {
    /// [`crate::laws::exact_weight`].
    Exact,
    /// [`crate::laws::exclusion_weight`].
    Exclusion,
    /// [`crate::laws::plummer_weight`].
    Plummer,
}
