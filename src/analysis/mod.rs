//! Measuring images: errors against a reference or a pair of them ([`metrics`]), a
//! perceptual difference ([`flip`]), summaries of repeated measurements ([`stats`]), fitted
//! convergence rates ([`fit`]) and log-log plots of them ([`plot`]).

pub(crate) mod fit;
pub(crate) mod flip;
pub mod metrics;
pub(crate) mod plot;
pub(crate) mod stats;
