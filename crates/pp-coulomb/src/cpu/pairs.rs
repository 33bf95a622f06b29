//! What a block kernel takes: the sources in structure-of-arrays form and which law it
//! applies. Both the portable kernel and the AVX-512 kernel import this module.

/// Sources in structure-of-arrays form, padded to a multiple of the kernel's lane count.
pub(crate) struct Sources<'a, T> {
    pub x: &'a [T],
    pub y: &'a [T],
    pub z: &'a [T],
    pub q: &'a [T],
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
