//! [`Config`]: how a [`Neighbors`](crate::Neighbors) search runs, besides its grid.

use crate::TraversalKernel;

/// Settings of a [`Neighbors`](crate::Neighbors) search; the defaults fit most uses.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Config {
    /// CPU traversal kernel of the sorted cells ([`TraversalKernel::Auto`]: the fastest this
    /// CPU supports). Ignored by the GPU backend.
    pub kernel: TraversalKernel,
}
