//! The `softplc` binary: see `softplc --help`.

fn main() -> std::process::ExitCode {
    softplc::cli::main()
}
