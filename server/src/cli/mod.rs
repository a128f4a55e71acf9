//! Subcommands of the `sable` binary.

pub mod bench;
pub mod bench_service;
pub mod run;
pub mod service;
