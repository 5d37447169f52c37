//! Measuring images: errors against a reference ([`metrics`]), fitted convergence rates
//! ([`fit`]) and log-log plots of them ([`plot`]).

pub mod fit;
pub mod metrics;
pub mod plot;
