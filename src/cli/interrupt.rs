//! Interrupts keep the work: the first SIGINT or SIGTERM asks the render to stop at the end of
//! its current pass (or slice of a Metropolis round); the command then writes what it has, with
//! its true sample count, prints its summary and exits with status 130. A second signal exits at
//! once.

use std::sync::OnceLock;
use std::sync::atomic::{AtomicBool, Ordering};

static STOP: AtomicBool = AtomicBool::new(false);
static INSTALLED: OnceLock<bool> = OnceLock::new();

/// Exit status after an interrupt (128 + SIGINT).
pub const EXIT_INTERRUPTED: i32 = 130;

/// Install the handler (once) and return the stop flag renders watch; `None` when no handler
/// could be installed (renders then simply cannot be interrupted gracefully).
pub fn stop_flag() -> Option<&'static AtomicBool> {
    let ok = *INSTALLED.get_or_init(|| {
        ctrlc::set_handler(|| {
            if STOP.swap(true, Ordering::SeqCst) {
                eprintln!("\ninterrupted again: exiting without writing");
                std::process::exit(EXIT_INTERRUPTED);
            }
            eprintln!(
                "\ninterrupted: finishing the current pass and writing what was rendered (interrupt again to quit at once)"
            );
        })
        .is_ok()
    });
    ok.then_some(&STOP)
}
