//! `sable`: the one entry point for users: run a scene locally (`run`, `validate`, `advise`, `bench`),
//! run the service (`serve`, `worker`), and talk to it (`submit`, `show`, `jobs`, `cancel`,
//! `samples`, `state`, `study`).

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
    /// The method advisor's choice for a scene file, its reasons and the scene's numbers.
    Advise(cli::advise::AdviseArgs),
    /// Measure a method's throughput on its standard scene.
    #[command(subcommand)]
    Bench(cli::bench::BenchCommand),
    /// Run the service: REST, gRPC, the SQLite job store and a local worker pool.
    Serve(cli::service::ServeArgs),
    /// Run a worker pool that leases jobs from a server over gRPC.
    Worker(cli::service::WorkerArgs),
    /// Submit a scene file to a server (optionally following it to the end).
    Submit(cli::service::SubmitArgs),
    /// Show one job.
    #[command(alias = "status")]
    Show(cli::service::StatusArgs),
    /// List jobs, newest first.
    #[command(alias = "list")]
    Jobs(cli::service::ListArgs),
    /// Cancel a queued or running job.
    Cancel(cli::service::CancelArgs),
    /// Print a job's samples.
    Samples(cli::service::SamplesArgs),
    /// Download the final state of a succeeded job (to start another scene from).
    State(cli::service::StateArgs),
    /// Submit a study (speed against accuracy, or a stability search), follow it, get its chart.
    Study(cli::study::StudyArgs),
    /// Run one job given on standard input (started by `serve` and `worker` for each job).
    #[command(hide = true)]
    JobRun,
}

fn main() -> std::process::ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Run(a) => cli::run::run(a),
        Command::Validate(a) => cli::run::validate(a),
        Command::Advise(a) => cli::advise::advise(a),
        Command::Bench(c) => cli::bench::run(c),
        Command::Serve(a) => cli::service::serve(a),
        Command::Worker(a) => cli::service::worker(a),
        Command::Submit(a) => cli::service::submit(a),
        Command::Show(a) => cli::service::status(a),
        Command::Jobs(a) => cli::service::list(a),
        Command::Cancel(a) => cli::service::cancel(a),
        Command::Samples(a) => cli::service::samples(a),
        Command::State(a) => cli::service::state(a),
        Command::Study(a) => cli::study::study(a),
        Command::JobRun => return std::process::ExitCode::from(sable_worker::child::job_process_main()),
    };
    match result {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}
