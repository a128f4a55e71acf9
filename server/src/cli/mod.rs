//! Subcommands of the `sable` binary.

pub mod advise;
pub mod bench;
pub mod bench_bpm;
pub mod bench_dem;
mod bench_prepare;
pub mod bench_scaling;
pub mod bench_service;
pub mod run;
pub mod service;
pub mod study;
mod trace;
