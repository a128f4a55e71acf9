//! `sable`: the one entry point for users. Today: `sable run` (a scene locally, no server) and
//! `sable bench` (throughput of a method on its standard scene).

mod cli;

use clap::{Parser, Subcommand};

/// Simulation of granular and soft-particle materials.
#[derive(Debug, Parser)]
#[command(name = "sable", version, about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Run a scene file locally and write its samples.
    Run(cli::run::RunArgs),
    /// Check a scene file and print every violation.
    Validate(cli::run::ValidateArgs),
    /// Measure a method's throughput on its standard scene.
    Bench(cli::bench::BenchArgs),
}

fn main() -> std::process::ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Run(a) => cli::run::run(a),
        Command::Validate(a) => cli::run::validate(a),
        Command::Bench(a) => cli::bench::bench(a),
    };
    match result {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}
