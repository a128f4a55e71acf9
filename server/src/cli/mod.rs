//! Subcommands of the `sable` binary.

pub mod bench;
pub mod run;
