//! The progress bar of a study, drawn on stderr while its runs go (hidden when stderr is not a
//! terminal, so logs and pipes get none of it).

use indicatif::{ProgressBar, ProgressFinish, ProgressStyle};
use std::io::IsTerminal as _;

/// A progress bar `label [#####   ] done/total runs (eta)` on stderr, as a callback taking the
/// number of runs done so far (the shape `Study::run` reports progress in); it clears itself when
/// `done` reaches `total` or when dropped. Any `total` is accepted (0 draws an empty bar).
pub fn bar(label: &str, total: u64) -> impl Fn(u64) + Sync + use<> {
    let bar = if std::io::stderr().is_terminal() {
        let style =
            ProgressStyle::with_template("{prefix:>16} [{bar:40}] {pos}/{len} runs ({eta})")
                .unwrap_or_else(|_| ProgressStyle::default_bar())
                .progress_chars("#> ");
        ProgressBar::new(total)
            .with_style(style)
            .with_prefix(label.to_owned())
            .with_finish(ProgressFinish::AndClear)
    } else {
        ProgressBar::hidden()
    };
    move |done: u64| {
        bar.set_position(done);
        if done >= total {
            bar.finish_and_clear();
        }
    }
}
