//! The `crestflow` binary. The command line lives in the library (`crestflow::app`) so that a
//! program with its own node kinds can reuse it with a different registry.

fn main() {
    quiet_on_closed_pipe();
    std::process::exit(crestflow::app::main_with(crestflow::registry()));
}

/// Output piped into a reader that stops early (`crestflow nodes | head`, a JSON log consumer
/// that quits) ends the process quietly, as for other Unix tools. Rust ignores SIGPIPE, so
/// without this the next `println!` panics with "Broken pipe" and a backtrace.
#[cfg(unix)]
fn quiet_on_closed_pipe() {
    // SAFETY: the first statement of `main`, before any other thread exists; SIG_DFL is a
    // valid disposition for SIGPIPE.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
}

#[cfg(not(unix))]
fn quiet_on_closed_pipe() {}
