//! Ctrl-C and SIGTERM: finish the current pass, save, and exit with the shell's code.

use std::io::IsTerminal;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

use anyhow::Context;

/// Flags raised by SIGINT and SIGTERM. At a terminal, a second signal of the same kind exits at
/// once (Ctrl-C pressed twice). Elsewhere every signal lets the pass finish and the checkpoint
/// be saved: schedulers often deliver one stop twice (at Slurm's time limit and on preemption
/// both the task and `srun`, which forwards it, get SIGTERM), and exiting on the duplicate
/// would lose the checkpoint. The scheduler's own SIGKILL deadline still bounds the wait.
pub struct Interrupt {
    interrupted: Arc<AtomicBool>,
    terminated: Arc<AtomicBool>,
}

/// Exit codes of a process stopped by SIGINT / SIGTERM (128 + signal number), as shells report.
pub const EXIT_SIGINT: u8 = 130;
pub const EXIT_SIGTERM: u8 = 143;

impl Interrupt {
    pub fn install() -> anyhow::Result<Interrupt> {
        use signal_hook::consts::{SIGINT, SIGTERM};
        use signal_hook::flag::{register, register_conditional_shutdown};
        let interrupted = Arc::new(AtomicBool::new(false));
        let terminated = Arc::new(AtomicBool::new(false));
        if std::io::stdin().is_terminal() {
            // Order matters: the shutdown hook sees the flag raised by the first signal only on
            // the second one.
            register_conditional_shutdown(SIGINT, EXIT_SIGINT as i32, Arc::clone(&interrupted))
                .context("cannot handle SIGINT")?;
            register_conditional_shutdown(SIGTERM, EXIT_SIGTERM as i32, Arc::clone(&terminated))
                .context("cannot handle SIGTERM")?;
        }
        register(SIGINT, Arc::clone(&interrupted)).context("cannot handle SIGINT")?;
        register(SIGTERM, Arc::clone(&terminated)).context("cannot handle SIGTERM")?;
        Ok(Interrupt {
            interrupted,
            terminated,
        })
    }

    /// The exit code to stop with, once a signal has arrived.
    pub fn requested(&self) -> Option<u8> {
        if self.interrupted.load(Ordering::Relaxed) {
            Some(EXIT_SIGINT)
        } else if self.terminated.load(Ordering::Relaxed) {
            Some(EXIT_SIGTERM)
        } else {
            None
        }
    }
}
