//! # sable-server
//!
//! The Sable service: the SQLite job store ([`store`]), the operations shared by both APIs
//! ([`api`]), the REST API ([`rest`], its routes in `routes`), the gRPC API ([`grpc`]), event streams ([`watch`]),
//! Prometheus metrics ([`metrics`]), studies and their driver ([`studies`]) and the server that
//! runs them with a local worker pool ([`serve`]), with bearer tokens ([`auth`]) and TLS
//! ([`tls`]). The `sable` binary is built from this crate.

pub mod api;
pub mod auth;
pub mod charts;
pub mod dashboard;
pub mod grpc;
pub mod idle;
pub mod metrics;
pub mod openapi;
pub mod rest;
mod rest_studies;
mod routes;
pub mod serve;
pub mod start_from;
pub mod store;
pub mod studies;
pub mod tls;
pub mod watch;

pub use serve::{ServeConfig, Server};
