//! `charted`: render scenes with unbiased and Metropolis light transport, compare algorithms at
//! equal time, and merge partial renders.

mod cli;

use clap::Parser;

fn main() {
    let args = cli::Cli::parse();
    if let Err(e) = cli::run(args) {
        eprintln!("error: {e}");
        std::process::exit(1);
    }
}
