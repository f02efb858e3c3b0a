//! Progress of a run: a bar on a terminal, one line per finished cell elsewhere (CI, Slurm and
//! `nohup` logs show nothing else until the end), both with an estimate of the time left.
//!
//! The estimate counts only cells still to render, at the mean time of the cells rendered so
//! far: cached cells cost nothing, and the plan knows which cells are cached before it starts.

use indicatif::{ProgressBar, ProgressStyle};
use std::io::IsTerminal;
use std::time::Instant;

/// `m:ss`, or `h:mm:ss` from an hour on.
pub(super) fn clock(seconds: f64) -> String {
    let s = seconds.max(0.0).round() as u64;
    let (h, m, s) = (s / 3600, s / 60 % 60, s % 60);
    if h > 0 {
        format!("{h}:{m:02}:{s:02}")
    } else {
        format!("{m}:{s:02}")
    }
}

/// The line of one finished cell: `[12/48] cornell-box · path · seed 1: rendered in 3.2 s ·
/// elapsed 0:41 · about 2:10 left`. `rendered`: the cell's seconds, `None` when it came from
/// the cache; `left`: the estimate, `None` before any cell was rendered.
pub(super) fn progress_line(
    done: usize,
    total: usize,
    cell: &str,
    rendered: Option<f64>,
    elapsed: f64,
    left: Option<f64>,
) -> String {
    let what = rendered.map_or("cached".to_string(), |s| format!("rendered in {s:.1} s"));
    let left = match left {
        Some(s) if done < total => format!(" · about {} left", clock(s)),
        Some(_) => String::new(),
        None => " · time left unknown until a cell is rendered".to_string(),
    };
    format!("[{done}/{total}] {cell}: {what} · elapsed {}{left}", clock(elapsed))
}

/// Progress over the cells of a plan.
pub(super) struct Progress {
    total: usize,
    done: usize,
    /// Cells of the plan that are not cached.
    to_render: usize,
    rendered: usize,
    render_seconds: f64,
    start: Instant,
    /// The terminal's bar; `None` when stderr is not a terminal (lines instead).
    bar: Option<ProgressBar>,
}

impl Progress {
    pub(super) fn new(total: usize, to_render: usize) -> Progress {
        let bar = std::io::stderr().is_terminal().then(|| {
            ProgressBar::new(total as u64).with_style(
                ProgressStyle::with_template("{elapsed_precise} [{bar:30}] {pos}/{len} {msg}")
                    .unwrap_or_else(|_| ProgressStyle::default_bar()),
            )
        });
        Progress {
            total,
            done: 0,
            to_render,
            rendered: 0,
            render_seconds: 0.0,
            start: Instant::now(),
            bar,
        }
    }

    /// Seconds left: the cells still to render at the mean time of those rendered.
    fn left(&self) -> Option<f64> {
        let still = self.to_render.saturating_sub(self.rendered);
        if still == 0 {
            return Some(0.0);
        }
        (self.rendered > 0).then(|| still as f64 * self.render_seconds / self.rendered as f64)
    }

    /// Shows the cell about to start (on the bar).
    pub(super) fn start_cell(&self, cell: &str) {
        if let Some(bar) = &self.bar {
            let left = self
                .left()
                .map_or(String::new(), |s| format!(" · about {} left", clock(s)));
            bar.set_message(format!("{cell}{left}"));
        }
    }

    /// Records a finished cell: `rendered` its seconds, `None` when cached.
    pub(super) fn finish_cell(&mut self, cell: &str, rendered: Option<f64>) {
        self.done += 1;
        if let Some(s) = rendered {
            self.rendered += 1;
            self.render_seconds += s;
        }
        match &self.bar {
            Some(bar) => bar.inc(1),
            None => eprintln!(
                "{}",
                progress_line(
                    self.done,
                    self.total,
                    cell,
                    rendered,
                    self.start.elapsed().as_secs_f64(),
                    self.left()
                )
            ),
        }
    }

    pub(super) fn finish(&self) {
        if let Some(bar) = &self.bar {
            bar.finish_and_clear();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn durations_read_as_clocks() {
        assert_eq!(clock(0.4), "0:00");
        assert_eq!(clock(41.0), "0:41");
        assert_eq!(clock(130.0), "2:10");
        assert_eq!(clock(3600.0 + 62.0), "1:01:02");
        assert_eq!(clock(-3.0), "0:00");
    }

    #[test]
    fn lines_say_what_the_cell_cost_and_what_is_left() {
        assert_eq!(
            progress_line(12, 48, "box · path · seed 1", Some(3.21), 41.0, Some(130.0)),
            "[12/48] box · path · seed 1: rendered in 3.2 s · elapsed 0:41 · about 2:10 left"
        );
        assert_eq!(
            progress_line(3, 48, "box · mps · seed 0", None, 0.2, None),
            "[3/48] box · mps · seed 0: cached · elapsed 0:00 · time left unknown until a cell is rendered"
        );
        assert_eq!(
            progress_line(48, 48, "box · mps · seed 2", Some(7200.0), 9000.0, Some(0.0)),
            "[48/48] box · mps · seed 2: rendered in 7200.0 s · elapsed 2:30:00"
        );
    }

    #[test]
    fn the_estimate_counts_only_cells_still_to_render() {
        let mut p = Progress {
            total: 10,
            done: 0,
            to_render: 4,
            rendered: 0,
            render_seconds: 0.0,
            start: Instant::now(),
            bar: None,
        };
        assert_eq!(p.left(), None);
        p.finish_cell("a", None);
        assert_eq!(p.left(), None, "a cached cell tells nothing of the cost");
        p.finish_cell("b", Some(2.0));
        p.finish_cell("c", Some(4.0));
        assert_eq!(p.left(), Some(2.0 * 3.0), "two left at 3 s each");
        p.finish_cell("d", Some(3.0));
        p.finish_cell("e", Some(3.0));
        assert_eq!(p.left(), Some(0.0));
    }
}
