//! The checkpoint options shared by the long time-stepping examples.

use std::path::{Path, PathBuf};

use simkit::cli::Checkpoints;

/// `--checkpoint-every N` and `--resume FILE`; flatten into an example's options with
/// `#[command(flatten)]`.
#[derive(clap::Args, Debug)]
pub struct CheckpointArgs {
    /// Write <out>/checkpoint.ckpt whenever the step count reaches a multiple of N
    /// (atomically, replacing the previous one; 0 = never)
    #[arg(long, value_name = "N", default_value_t = 0)]
    pub checkpoint_every: u32,
    /// Continue the run saved in FILE (with the same scene options) up to the total the
    /// other options ask for, bit for bit as the uninterrupted run
    #[arg(long, value_name = "FILE")]
    pub resume: Option<PathBuf>,
}

impl CheckpointArgs {
    /// The checkpoint schedule, writing to `out/checkpoint.ckpt`.
    pub fn checkpoints(&self, out: &Path) -> Checkpoints {
        Checkpoints::new(self.checkpoint_every, self.resume.clone(), out)
    }
}
