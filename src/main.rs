#![recursion_limit = "256"]
//! The `raysplat` binary: a thin front end over the library (see `cli`).

mod cli;

fn main() {
    std::process::exit(cli::main());
}
