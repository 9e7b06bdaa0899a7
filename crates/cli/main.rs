//! The `crestflow` binary. The command line lives in the library (`crestflow::app`) so that a
//! program with its own node kinds can reuse it with a different registry.

fn main() {
    std::process::exit(crestflow::app::main_with(crestflow::registry()));
}
