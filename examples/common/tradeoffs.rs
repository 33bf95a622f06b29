//! Where the trade-off sweeps write: `out/<example>/` by default, `docs/tradeoffs/` only
//! when asked to.

use std::path::PathBuf;

/// `--update-docs`; flatten into a sweep's options with `#[command(flatten)]`.
#[derive(clap::Args, Debug)]
pub struct TradeoffArgs {
    /// Write the tables and plots into docs/tradeoffs/ (the tracked documentation) instead of
    /// out/<example>/
    #[arg(long)]
    pub update_docs: bool,
}

impl TradeoffArgs {
    /// The output folder: `docs/tradeoffs` with `--update-docs`, else `out/<example>`.
    pub fn dir(&self, example: &str) -> PathBuf {
        if self.update_docs {
            PathBuf::from("docs/tradeoffs")
        } else {
            PathBuf::from("out").join(example)
        }
    }
}
