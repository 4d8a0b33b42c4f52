//! `charted`: render scenes with unbiased and Metropolis light transport, compare algorithms at
//! equal time, and merge partial renders.

mod cli;

use clap::Parser;

fn main() {
    let args = cli::Cli::parse();
    match cli::run(args) {
        Ok(()) => {}
        Err(cli::CliError::Interrupted) => std::process::exit(cli::interrupt::EXIT_INTERRUPTED),
        Err(e) => {
            eprintln!("error: {e}");
            std::process::exit(1);
        }
    }
}
