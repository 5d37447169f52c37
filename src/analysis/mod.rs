//! Measuring images: errors against a reference ([`metrics`]), fitted convergence rates
//! ([`fit`]) and log-log plots of them ([`plot`]).

pub(crate) mod fit;
pub mod metrics;
pub(crate) mod plot;
