//! Temporal denoising of a shot (`--temporal`): each frame's noisy colour is averaged with the
//! frames before it where its surfaces are found there ([`reproject`]), then denoised, so that
//! the noise left moves with the surfaces instead of flickering in place.
//!
//! Frame `n` reads frames `n - 1` and `n - 2` ([`HISTORY`]) of its shot, each rendered exactly
//! as that frame renders itself: its result depends on those frames and no others, so it is
//! the same rendered alone, in a sequence, in any chunk of a farm or after a resume. A frame
//! whose earlier frames were not rendered in this run renders them first (they are not
//! written): a chunk overlaps the one before it by those frames.

use std::time::Instant;

use super::budget::Budget;
use super::denoised::denoise_with;
use super::device::ShotGeometry;
use super::frame::{Denoising, FrameResult, frame_failed, render};
use crate::denoise::denoiser::Denoiser;
use crate::denoise::reproject::{self, HISTORY, TemporalFrame};
use crate::error::Error;
use crate::pass::{Pass, PassSet};
use crate::passes::PassImages;
use crate::points::FramePoints;
use crate::scene::Scene;

/// A temporal denoiser for the frames of one shot, keeping the last frames it rendered.
pub struct TemporalDenoiser<'d> {
    denoiser: &'d Denoiser,
    /// The shot's last rendered frames, oldest first, at most [`HISTORY`] + 1.
    history: Vec<(u32, TemporalFrame)>,
}

impl<'d> TemporalDenoiser<'d> {
    /// A temporal denoiser of one shot's frames (start a new one for another shot).
    pub fn new(denoiser: &'d Denoiser) -> TemporalDenoiser<'d> {
        TemporalDenoiser {
            denoiser,
            history: Vec::new(),
        }
    }

    /// Renders frame `frame` of `scene` on the device of `geometry` (as
    /// [`render_shot_frame`](super::render_shot_frame) does) and denoises it with the
    /// [`HISTORY`] frames of the shot before it, rendering those first if this denoiser has
    /// not rendered them. The result's
    /// [`FrameStats::relative_error`](super::FrameStats::relative_error) is the estimated
    /// error of the frame so denoised; its time and the earlier frames' are in its figures.
    /// `progress` counts the frame's own samples.
    /// `points` are the frame's points of the scene's point caches, and `points_of` reads an
    /// earlier frame's.
    #[allow(clippy::too_many_arguments)]
    pub fn render(
        &mut self,
        scene: &Scene,
        geometry: &ShotGeometry,
        points: &FramePoints,
        points_of: &dyn Fn(u32) -> Result<FramePoints, Error>,
        frame: u32,
        budget: &Budget,
        progress: &(dyn Fn(u64) + Sync),
    ) -> Result<FrameResult, Error> {
        let start = Instant::now();
        let first = scene.shot.first_frame;
        let earlier: Vec<u32> = (frame.saturating_sub(HISTORY as u32)..frame)
            .filter(|&k| k >= first)
            .collect();
        self.history.retain(|(k, _)| earlier.contains(k));
        for &k in &earlier {
            if !self.history.iter().any(|(j, _)| *j == k) {
                let r = self.render_raw(scene, geometry, &points_of(k)?, k, budget, &|_| {})?;
                self.history.push((k, temporal_frame(&r)));
            }
        }
        self.history.sort_by_key(|(k, _)| *k);
        let mut result = self.render_raw(scene, geometry, points, frame, budget, progress)?;
        let current = temporal_frame(&result);
        // The frame before first.
        let before: Vec<&TemporalFrame> = self.history.iter().rev().map(|(_, f)| f).collect();
        let accumulated = reproject::accumulate(&current, &before);
        let denoise_start = Instant::now();
        let mut made = denoise_with(
            &result.film,
            &result.layout,
            self.denoiser,
            Some(&accumulated),
        )
        .map_err(|e| frame_failed(frame, e.into()))?;
        made.frames_averaged = Some(
            accumulated.frames.iter().map(|&f| f as f64).sum::<f64>()
                / accumulated.frames.len().max(1) as f64,
        );
        let st = &mut result.stats;
        st.denoise_seconds += denoise_start.elapsed().as_secs_f64();
        st.relative_error = made.relative_error;
        result.denoised = Some(made);
        self.history.push((frame, current));
        // Everything this call did, the earlier frames included.
        let extra = start.elapsed().as_secs_f64() - st.prepare_seconds - st.render_seconds;
        st.render_seconds += extra.max(0.0);
        Ok(result)
    }

    fn render_raw(
        &self,
        scene: &Scene,
        geometry: &ShotGeometry,
        points: &FramePoints,
        frame: u32,
        budget: &Budget,
        progress: &(dyn Fn(u64) + Sync),
    ) -> Result<FrameResult, Error> {
        render(
            scene,
            geometry.on(),
            points,
            frame,
            budget,
            Denoising::Temporal(self.denoiser),
            progress,
        )
        .map_err(|e| frame_failed(frame, e))
    }
}

/// What temporal denoising reads of a rendered frame (its film keeps depth, normal and
/// motion: `Layout::for_denoising`).
fn temporal_frame(result: &FrameResult) -> TemporalFrame {
    let film = &result.film;
    let set = PassSet::EMPTY
        .with(Pass::Depth)
        .with(Pass::Normal)
        .with(Pass::Motion);
    let images = PassImages::of(set, &result.layout, film);
    let channel = |name: &str| images.channel(name).expect("a kept pass");
    let interleave = |names: &[&str]| -> Vec<f32> {
        let cs: Vec<&[f32]> = names.iter().map(|n| channel(n)).collect();
        (0..cs[0].len())
            .flat_map(|i| cs.iter().map(move |c| c[i]))
            .collect()
    };
    let (mut a, mut b, mut variance) = (Vec::new(), Vec::new(), Vec::new());
    for (x, y) in (0..film.height).flat_map(|y| (0..film.width).map(move |x| (x, y))) {
        let pixel = film.pixel(x, y);
        let (pa, pb) = pixel.replicate_means();
        for (out, v) in [
            (&mut a, pa),
            (&mut b, pb),
            (&mut variance, pixel.variance_of_mean()),
        ] {
            let c = [v.x as f32, v.y as f32, v.z as f32];
            out.extend(if c.iter().all(|c| c.is_finite()) {
                c
            } else {
                [0.0; 3]
            });
        }
    }
    TemporalFrame {
        width: film.width as usize,
        height: film.height as usize,
        a,
        b,
        variance,
        depth: channel("Z").to_vec(),
        normal: interleave(&["N.X", "N.Y", "N.Z"]),
        backward: interleave(&["backward.u", "backward.v"]),
    }
}
