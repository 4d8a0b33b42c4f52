//! `charted`: render scenes with unbiased and Metropolis light transport, compare algorithms at
//! equal time, and merge partial renders.

mod cli;

use clap::Parser;

fn main() {
    quiet_on_closed_stdout();
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

/// A closed standard output (`charted diff a.exr b.exr | head -1`) ends the program quietly with
/// the status of a broken pipe (141, as Unix tools killed by SIGPIPE report), instead of the
/// panic the standard library raises when `println!` meets `EPIPE`. Other panics are reported as
/// before.
fn quiet_on_closed_stdout() {
    let report = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        let payload = info.payload();
        let message = payload
            .downcast_ref::<String>()
            .map(String::as_str)
            .or_else(|| payload.downcast_ref::<&str>().copied())
            .unwrap_or("");
        if message.contains("failed printing to stdout") && message.contains("Broken pipe") {
            std::process::exit(141);
        }
        report(info);
    }));
}
