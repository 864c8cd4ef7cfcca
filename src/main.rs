//! `drivedeck`: the window, one-shot commands and the simulated drive's servers.

fn main() -> std::process::ExitCode {
    drivedeck::ui::timings::mark_start();
    drivedeck::cli::main()
}
