//! The `vitrum` command line: a thin wrapper over [`vitrum::cli`].

fn main() {
    std::process::exit(vitrum::cli::main());
}
