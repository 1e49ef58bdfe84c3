//! Ctrl-C during a build: the first asks long stages (the population estimators) to stop at
//! their next iteration and the executor to start nothing new, so the build ends with the
//! finished stages cached and the interrupted ones leaving nothing behind; a second Ctrl-C
//! exits at once (also safe: results only ever appear by rename).

use std::sync::atomic::{AtomicBool, Ordering};

static INTERRUPTED: AtomicBool = AtomicBool::new(false);

/// Installs the handler (once per process; later calls are ignored).
pub fn install() {
    let _ = ctrlc::set_handler(|| {
        if INTERRUPTED.swap(true, Ordering::SeqCst) {
            eprintln!("\nhydrofit: interrupted again; stopping now");
            std::process::exit(130);
        }
        eprintln!(
            "\nhydrofit: interrupted; stopping the running stages (Ctrl-C again to stop at once)"
        );
    });
}

pub fn requested() -> bool {
    INTERRUPTED.load(Ordering::Relaxed)
}

/// For tests: behave as if Ctrl-C had been pressed.
pub fn request() {
    INTERRUPTED.store(true, Ordering::SeqCst);
}
