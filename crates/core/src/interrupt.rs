//! Ctrl-C during a build: the first asks long stages (estimators, searches, the adaptive
//! identifier, the estimator comparison) to stop at their next iteration and the executor to
//! start nothing new, so the build ends with the finished stages cached and the interrupted
//! ones leaving nothing behind; a second Ctrl-C exits at once (also safe: results only ever
//! appear by rename).

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

/// An error once Ctrl-C was pressed: for `?` in a stage's long loops. A loop that cannot
/// return an error breaks on [`requested`] instead; the executor then drops what the stage
/// wrote, so a loop cut short is never cached.
pub fn check() -> anyhow::Result<()> {
    anyhow::ensure!(!requested(), "interrupted (Ctrl-C)");
    Ok(())
}

/// For tests: behave as if Ctrl-C had been pressed.
pub fn request() {
    INTERRUPTED.store(true, Ordering::SeqCst);
}
