//! # chainsweep-cli — the `chainsweep` command line
//!
//! A thin front end over the engine ([`chainsweep`]): [`cli`] parses the arguments, calls the
//! engine and prints its reports (text, or JSON with `--json`); [`progress`] is the progress
//! display the engine reports to while a sweep runs. It holds no physics, no file layout and no
//! scheduling: those are the engine's and the solver's. The Python package's `chainsweep`
//! command runs the same code ([`cli::main_from`]).
#![warn(missing_docs)]

/// `println!` that ignores write errors: a reader that went away (`| head`) must never end a
/// command, least of all a sweep (output to a closed pipe is dropped).
macro_rules! outln {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stdout(), $($arg)*);
    }};
}

/// `eprintln!` that ignores write errors (progress and reports on stderr; see [`outln`]).
macro_rules! errln {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stderr(), $($arg)*);
    }};
}

pub mod cli;
pub mod progress;

/// Git revision the command line was built from (`unknown` outside a git checkout); the engine
/// records it in every file it writes once [`cli::main_from`] has told it
/// ([`chainsweep::init`]).
pub const GIT_REVISION: &str = env!("CHAINSWEEP_GIT_REVISION");
