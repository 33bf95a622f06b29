//! The backend-neutral engine interface behind [`crate::Dem`].

use simkit_backend::Result;

use crate::State;
use crate::prepared::Prepared;

/// One backend instance (CPU at some dimension and precision, or GPU).
pub(crate) trait Engine: Send {
    fn advance(&mut self, steps: u32) -> Result<()>;
    fn snapshot(&mut self) -> Result<State>;
    fn prepared(&self) -> &Prepared;
    fn name(&self) -> String;
}
