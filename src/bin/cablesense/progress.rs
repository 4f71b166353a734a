//! Progress bars for the long sweeps (`pareto`, `stability`): drawn on stderr only
//! when it is a terminal and `--quiet` is not given, so logs and tests stay clean.

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::io::IsTerminal;

/// A bar of `len` steps, hidden when `quiet` or stderr is not a terminal.
pub fn bar(len: u64, quiet: bool) -> ProgressBar {
    if quiet || !std::io::stderr().is_terminal() {
        return ProgressBar::hidden();
    }
    let pb = ProgressBar::with_draw_target(Some(len), ProgressDrawTarget::stderr());
    let style =
        ProgressStyle::with_template("{elapsed_precise} [{wide_bar}] {pos}/{len} eta {eta} {msg}")
            .map(|s| s.progress_chars("=> "))
            .unwrap_or_else(|_| ProgressStyle::default_bar());
    pb.set_style(style);
    pb
}

/// A status line on stderr: above the bar when it is drawn, plain otherwise; nothing
/// with `--quiet`.
pub fn note(pb: &ProgressBar, quiet: bool, line: &str) {
    if quiet {
        return;
    }
    if pb.is_hidden() {
        eprintln!("{line}");
    } else {
        pb.println(line);
    }
}

/// Says on stderr when a long run has reported no progress for a while, even with
/// `--quiet` (which hides the bar, not a run that is stuck): a background thread
/// that wakes every `interval / 60` and writes one line per silent `interval`,
/// naming the last progress it saw. Stops when dropped.
pub struct Watchdog {
    state: std::sync::Arc<WatchState>,
    thread: Option<std::thread::JoinHandle<()>>,
}

struct WatchState {
    /// The last progress message and when it came.
    last: std::sync::Mutex<(std::time::Instant, String)>,
    stop: std::sync::atomic::AtomicBool,
}

/// Silence after which a run says it has not moved (s).
pub const WATCHDOG_INTERVAL_S: u64 = 60;

impl Watchdog {
    /// A watchdog writing its lines to stderr, prefixed by `label`.
    pub fn stderr(label: &str) -> Self {
        let label = label.to_string();
        Self::new(
            std::time::Duration::from_secs(WATCHDOG_INTERVAL_S),
            move |line| eprintln!("{label}: {line}"),
        )
    }

    /// A watchdog that gives `sink` one line per silent `interval`.
    pub fn new(interval: std::time::Duration, sink: impl Fn(&str) + Send + 'static) -> Self {
        use std::sync::atomic::Ordering;
        let state = std::sync::Arc::new(WatchState {
            last: std::sync::Mutex::new((std::time::Instant::now(), "starting".into())),
            stop: std::sync::atomic::AtomicBool::new(false),
        });
        let watched = state.clone();
        let nap = (interval / 60).max(std::time::Duration::from_millis(1));
        let thread = std::thread::spawn(move || {
            let started = std::time::Instant::now();
            let mut said = started;
            while !watched.stop.load(Ordering::Relaxed) {
                std::thread::park_timeout(nap);
                let (at, what) = match watched.last.lock() {
                    Ok(g) => (g.0, g.1.clone()),
                    Err(_) => return,
                };
                let now = std::time::Instant::now();
                let quiet_since = at.max(said);
                if now.duration_since(quiet_since) >= interval {
                    sink(&format!(
                        "no progress for {:.0} s (running {:.0} s; last: {what}); still working",
                        now.duration_since(at).as_secs_f64(),
                        now.duration_since(started).as_secs_f64()
                    ));
                    said = now;
                }
            }
        });
        Self {
            state,
            thread: Some(thread),
        }
    }

    /// Record progress (`what`: the stage, iteration or rows done).
    pub fn tick(&self, what: &str) {
        if let Ok(mut g) = self.state.last.lock() {
            g.0 = std::time::Instant::now();
            what.clone_into(&mut g.1);
        }
    }
}

impl Drop for Watchdog {
    fn drop(&mut self) {
        self.state
            .stop
            .store(true, std::sync::atomic::Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            t.thread().unpark();
            let _ = t.join();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::Watchdog;
    use std::sync::{Arc, Mutex};
    use std::time::Duration;

    fn lines_over(ticks: bool) -> Vec<String> {
        let seen = Arc::new(Mutex::new(Vec::new()));
        let sink = seen.clone();
        let dog = Watchdog::new(Duration::from_millis(120), move |l| {
            sink.lock().unwrap().push(l.to_string())
        });
        for i in 0..40 {
            std::thread::sleep(Duration::from_millis(10));
            if ticks {
                dog.tick(&format!("row {i}"));
            }
        }
        drop(dog);
        let out = seen.lock().unwrap().clone();
        out
    }

    /// 400 ms of silence against a 120 ms interval: at least two lines, each
    /// naming the last progress; steady progress every 10 ms: none.
    #[test]
    fn a_silent_run_says_so_and_a_moving_one_does_not() {
        let silent = lines_over(false);
        assert!(silent.len() >= 2, "{silent:?}");
        assert!(silent[0].contains("last: starting"), "{silent:?}");
        assert!(lines_over(true).is_empty());
    }
}
