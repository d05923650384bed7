/// mimalloc, not glibc's malloc: see [`realcam::allocator`].
#[global_allocator]
static ALLOCATOR: realcam::allocator::Allocator = realcam::allocator::Allocator {};

fn main() -> std::process::ExitCode {
    realcam::allocator::return_freed_memory_at_once();
    end_quietly_when_the_reader_leaves();
    realcam::cli::main()
}

/// The commands whose output is what they print on standard output.
const PRINTING_COMMANDS: [&str; 4] = ["lens", "lenses", "glass", "bench"];

/// Restores SIGPIPE's default action, ending the process, for the commands that print.
///
/// Rust starts a program with SIGPIPE ignored, so a write to a pipe whose reader has gone
/// (`realcam lens … --json | head -1`) fails with EPIPE, and `println!` panics on that
/// ("failed printing to stdout: Broken pipe", exit 101). With the default action the kernel
/// ends realcam quietly at that write, as it ends any Unix tool, without every print having to
/// handle the error. The other commands keep SIGPIPE ignored: `serve`, because a browser that
/// disconnects must be an EPIPE error on that connection's socket, not the end of the server;
/// `render` and `merge`, because an image output whose reader went away (a FIFO, `-`) is an
/// error naming the output, never a silent end (README, "Outputs").
fn end_quietly_when_the_reader_leaves() {
    // The command is the first argument: `Cli` has no options before its subcommand.
    #[cfg(unix)]
    if std::env::args_os()
        .nth(1)
        .is_some_and(|command| PRINTING_COMMANDS.iter().any(|name| command == *name))
    {
        // SAFETY: the first thing `main` does, before any other thread exists; SIG_DFL
        // installs no handler.
        unsafe {
            libc::signal(libc::SIGPIPE, libc::SIG_DFL);
        }
    }
}
