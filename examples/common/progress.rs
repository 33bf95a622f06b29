//! The examples' progress bars (indicatif), on stderr and drawn only when stderr is a
//! terminal: `label [#####-----] 512/1,000 steps, 830.5/s, ETA 1s`.

use indicatif::{ProgressBar, ProgressStyle};

/// A bar counting `len` items of `unit` (e.g. "steps", "runs"), labelled `label`.
///
/// Print through [`ProgressBar::suspend`] while it is drawn, so that lines do not mix with
/// the bar; [`ProgressBar::finish`] leaves the final count on the terminal.
pub fn bar(label: &str, len: u64, unit: &str) -> ProgressBar {
    let template = format!(
        "{{msg}} [{{bar:30}}] {{human_pos}}/{{human_len}} {unit}, {{per_sec:1}}, ETA {{eta}}"
    );
    let style = ProgressStyle::with_template(&template)
        .expect("the progress template is valid")
        .progress_chars("#>-");
    ProgressBar::new(len)
        .with_style(style)
        .with_message(label.to_string())
}
