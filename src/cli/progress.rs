//! Messages and the progress bar on stderr. `-q` silences both; the bar draws only on a
//! terminal, and only once a run has lasted a moment.

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

/// `-q`: no messages but errors.
static QUIET: AtomicBool = AtomicBool::new(false);

/// The bar of the run in progress, so that messages print above it instead of through it.
static BAR: Mutex<Option<ProgressBar>> = Mutex::new(None);

/// How long a run goes before its bar appears: short runs stay quiet.
const MOMENT: Duration = Duration::from_millis(400);

pub fn set_quiet(quiet: bool) {
    QUIET.store(quiet, Ordering::Relaxed);
}

/// A message on stderr, unless `-q`.
pub fn note(message: String) {
    if QUIET.load(Ordering::Relaxed) {
        return;
    }
    match BAR.lock().unwrap_or_else(|e| e.into_inner()).as_ref() {
        Some(bar) => bar.suspend(|| eprintln!("{message}")),
        None => eprintln!("{message}"),
    }
}

/// The stages of one run and, while rasterising, the rows done.
pub struct Progress {
    bar: ProgressBar,
}

impl Progress {
    pub fn start() -> Progress {
        let bar = ProgressBar::with_draw_target(None, ProgressDrawTarget::hidden());
        bar.set_style(ProgressStyle::with_template("{spinner} {msg} {elapsed}").expect("a valid template"));
        *BAR.lock().unwrap_or_else(|e| e.into_inner()) = Some(bar.clone());
        if !QUIET.load(Ordering::Relaxed) {
            // Reveal the bar after a moment, even in the middle of one long stage.
            let weak = bar.downgrade();
            std::thread::spawn(move || {
                std::thread::sleep(MOMENT);
                let _running = BAR.lock().unwrap_or_else(|e| e.into_inner()); // not while it finishes
                if let Some(bar) = weak.upgrade().filter(|bar| !bar.is_finished()) {
                    bar.set_draw_target(ProgressDrawTarget::stderr());
                    bar.enable_steady_tick(Duration::from_millis(120));
                }
            });
        }
        Progress { bar }
    }

    /// A stage with no count (reading, triangulating).
    pub fn stage(&self, message: impl Into<String>) {
        self.bar.set_message(message.into());
    }

    /// A stage counted in rows.
    pub fn rows(&self, message: impl Into<String>, total: u64) {
        self.bar.set_style(
            ProgressStyle::with_template("{spinner} {msg} [{bar:32}] {human_pos}/{human_len} rows, {elapsed} (ETA {eta})")
                .expect("a valid template")
                .progress_chars("=> "),
        );
        self.bar.set_length(total);
        self.bar.set_position(0);
        self.stage(message);
    }

    pub fn advance(&self, rows: u64) {
        self.bar.inc(rows);
    }
}

impl tileraster::dem::Progress for Progress {
    fn stage(&self, what: &str) {
        Progress::stage(self, what)
    }

    fn rows(&self, what: &str, total: u64) {
        Progress::rows(self, what, total)
    }

    fn advance(&self, rows: u64) {
        Progress::advance(self, rows)
    }
}

impl Drop for Progress {
    fn drop(&mut self) {
        let mut running = BAR.lock().unwrap_or_else(|e| e.into_inner());
        self.bar.finish_and_clear();
        *running = None;
    }
}
