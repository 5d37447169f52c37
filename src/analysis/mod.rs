//! Measuring renders for `converge`: a perceptual difference ([`flip`]), summaries of
//! repeated measurements ([`stats`]), fitted convergence rates ([`fit`]) and log-log plots of
//! them ([`plot`]). The errors themselves are [`raytrace_core::metrics`]'.

pub(crate) mod fit;
pub(crate) mod flip;
pub(crate) mod plot;
pub(crate) mod stats;
