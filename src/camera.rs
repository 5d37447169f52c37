//! The camera: a thin lens that may move during the shot.

use glam::DVec3;

use crate::motion::Motion;

/// The camera as the scene describes it, for the whole shot.
#[derive(Clone, Debug, PartialEq)]
pub struct CameraRig {
    /// Where the camera is. A turntable (`orbit`) is a [`Motion::Orbit`] about `look_at` and
    /// `up`; `keyframes` become [`Motion::Keyframes`] of both points.
    pub look_from: Motion,
    /// Where it looks.
    pub look_at: Motion,
    /// The up direction (not necessarily unit length; not parallel to the view direction).
    pub up: DVec3,
    /// Vertical field of view in degrees, in (0, 180).
    pub vfov: f64,
    /// Lens diameter; 0 is a pinhole.
    pub aperture: f64,
    /// Distance to the plane in focus; `None`: the distance from `look_from` to `look_at` at
    /// the ray's time.
    pub focus_distance: Option<f64>,
}
