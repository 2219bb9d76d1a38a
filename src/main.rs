//! The `clothopt` command line: list scenes, simulate, differentiate, optimize, export.
//!
//! The commands live in [`cli`], one module per subcommand; this file only parses the arguments,
//! runs the command and turns its outcome into the exit code.

use clap::Parser;
use clothopt::error_chain;

mod cli;

fn main() {
    match cli::run(cli::Cli::parse()) {
        Ok(code) => std::process::exit(code),
        Err(e) => {
            eprintln!("error: {}", error_chain(e.as_ref()));
            std::process::exit(1);
        }
    }
}
