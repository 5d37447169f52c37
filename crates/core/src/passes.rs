//! Passes for compositing: what a pixel's camera samples say besides their colour (coverage,
//! depth, normal, albedo, motion, variance), as the scene format's "Passes" names them
//! ([`crate::pass`] names them; this room computes them).
//!
//! A frame with passes keeps, beside each pixel's colour accumulator, a few sums per sample
//! ([`SumLayout`]: only those of the requested passes, in one flat buffer). Each sample adds
//! what its camera ray's first hit gives ([`PassContext::record`]); the sums are added in
//! sample order whatever the passes of a budgeted render, so a frame's passes are the same bits
//! however it was split. A frame without passes allocates nothing here and does nothing per
//! sample.
//!
//! Motion vectors come from the true motion: the first-hit point, taken relative to its
//! sphere's centre at the sample's time, is carried to one frame period later and earlier by
//! its sphere's own motion over the whole shot ([`crate::motion::Motion::at`], which holds at
//! any time, not only in the frame's shutter), and projected through the camera at those times
//! ([`View::project`], which does not clip).

use glam::{DVec2, DVec3};

use crate::camera::{CameraRig, View};
use crate::film::{Film, Pixel};
use crate::hit::Hit;
use crate::image::{Image, Precision, Values};
use crate::material::{Background, Material};
use crate::pass::{Pass, PassSet};
use crate::points::FramePoints;
use crate::ray::Ray;
use crate::sphere::SphereDesc;

/// Where each requested pass keeps its per-pixel sums in a pixel's run of `stride` numbers.
/// Only the requested passes have sums: the hit count (alpha, depth, normal and motion divide
/// by it), the depth, the normal (3), the albedo (3) and the motion (4). Variance comes from
/// the colour's own accumulator and needs none. A stage that finishes frames may keep sums of
/// passes it reads without writing them ([`SumLayout::keeping`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SumLayout {
    /// The passes written.
    passes: PassSet,
    /// The passes whose sums are kept: those written, and those a finishing stage reads.
    kept: PassSet,
    /// Whether the hits are counted (alpha, depth, normal or motion kept).
    counts_hits: bool,
    hits: usize,
    depth: usize,
    normal: usize,
    albedo: usize,
    motion: usize,
    /// Numbers per pixel.
    pub stride: usize,
}

/// Where a [`SumLayout`] keeps each sum in a pixel's run of [`SumLayout::stride`] numbers, as
/// [`PassContext::record`] adds them: the hit count (1), the depth (1), the normal (3), the
/// albedo (3) and the motion (forward u, v, backward u, v). `None` where the sum is not kept.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Slots {
    pub hits: Option<usize>,
    pub depth: Option<usize>,
    pub normal: Option<usize>,
    pub albedo: Option<usize>,
    pub motion: Option<usize>,
}

impl SumLayout {
    /// The sums `passes` need.
    pub fn new(passes: PassSet) -> SumLayout {
        SumLayout::keeping(passes, PassSet::EMPTY)
    }

    /// The sums `passes` need, and those of `read`, passes a finishing stage reads without
    /// writing them.
    pub fn keeping(passes: PassSet, read: PassSet) -> SumLayout {
        let kept = read.iter().fold(passes, PassSet::with);
        let mut stride = 0;
        let mut slot = |used: bool, n: usize| {
            let at = stride;
            if used {
                stride += n;
            }
            at
        };
        let counts_hits = kept.iter().any(uses_hits);
        let hits = slot(counts_hits, 1);
        let depth = slot(kept.contains(Pass::Depth), 1);
        let normal = slot(kept.contains(Pass::Normal), 3);
        let albedo = slot(kept.contains(Pass::Albedo), 3);
        let motion = slot(kept.contains(Pass::Motion), 4);
        SumLayout {
            passes,
            kept,
            counts_hits,
            hits,
            depth,
            normal,
            albedo,
            motion,
            stride,
        }
    }

    /// The passes written.
    pub fn passes(&self) -> PassSet {
        self.passes
    }

    /// The passes whose sums are kept (those written among them).
    pub fn kept(&self) -> PassSet {
        self.kept
    }

    /// Where each kept pass's sums start in a pixel's run (`None`: not kept), for a tracer
    /// that adds them elsewhere (the GPU's, `raytrace_gpu`).
    pub fn slots(&self) -> Slots {
        let kept = self.kept;
        Slots {
            hits: self.counts_hits.then_some(self.hits),
            depth: kept.contains(Pass::Depth).then_some(self.depth),
            normal: kept.contains(Pass::Normal).then_some(self.normal),
            albedo: kept.contains(Pass::Albedo).then_some(self.albedo),
            motion: kept.contains(Pass::Motion).then_some(self.motion),
        }
    }
}

/// The points of a frame without point caches.
static NO_POINTS: FramePoints = FramePoints { sets: Vec::new() };

/// What a frame needs to compute its samples' passes.
#[derive(Clone, Debug)]
pub(crate) struct PassContext<'a> {
    /// Where the sums go.
    pub layout: SumLayout,
    spheres: &'a [SphereDesc],
    /// The frame's points, spheres `spheres.len()` on.
    points: &'a FramePoints,
    background: Background,
    camera: &'a CameraRig,
    /// The camera's view when it never moves in the shot (then no view is computed per sample).
    still_view: Option<View>,
    /// One frame period, 1 / fps, in seconds.
    period: f64,
    width: u32,
    height: u32,
}

impl<'a> PassContext<'a> {
    /// The context of a frame of `width` x `height` pixels of a shot at `fps` frames per
    /// second, for `passes`.
    pub(crate) fn new(
        layout: SumLayout,
        spheres: &'a [SphereDesc],
        background: Background,
        camera: &'a CameraRig,
        fps: f64,
        width: u32,
        height: u32,
    ) -> PassContext<'a> {
        let animated = camera.look_from.is_animated() || camera.look_at.is_animated();
        PassContext {
            layout,
            spheres,
            points: &NO_POINTS,
            background,
            camera,
            still_view: (!animated).then(|| camera.view_at(0.0, width, height)),
            period: 1.0 / fps,
            width,
            height,
        }
    }

    /// The context with the frame's points, spheres `spheres.len()` on (none without).
    pub(crate) fn with_points(self, points: &'a FramePoints) -> PassContext<'a> {
        PassContext { points, ..self }
    }

    /// The camera's view at time `t`.
    fn view_at(&self, t: f64) -> View {
        match self.still_view {
            Some(v) => v,
            None => self.camera.view_at(t, self.width, self.height),
        }
    }

    /// Adds one sample to a pixel's sums `slots` (its run of [`SumLayout::stride`] numbers): the
    /// camera `ray`, seen through `view` (the camera at the ray's time), and the ray's first
    /// `hit` (`None`: it missed every sphere, or was not traced).
    #[inline]
    pub(crate) fn record(&self, slots: &mut [f64], ray: &Ray, view: &View, hit: Option<&Hit>) {
        let l = &self.layout;
        let passes = l.kept;
        let Some(hit) = hit else {
            if passes.contains(Pass::Albedo) {
                let b = self.background.radiance(ray.dir);
                // A ray that was not traced (not finite) adds nothing.
                if b.is_finite() {
                    add3(&mut slots[l.albedo..], b);
                }
            }
            return;
        };
        let p = hit.surface.p;
        if l.counts_hits {
            slots[l.hits] += 1.0;
        }
        if passes.contains(Pass::Depth) {
            slots[l.depth] += view.depth(p);
        }
        if passes.contains(Pass::Normal) {
            add3(&mut slots[l.normal..], hit.surface.normal);
        }
        if passes.contains(Pass::Albedo) {
            add3(&mut slots[l.albedo..], albedo(&hit.material));
        }
        if passes.contains(Pass::Motion) {
            let (forward, backward) = self.motion(p, hit.sphere, ray.time, view);
            let m = &mut slots[l.motion..l.motion + 4];
            m[0] += forward.x;
            m[1] += forward.y;
            m[2] += backward.x;
            m[3] += backward.y;
        }
    }

    /// The displacements in pixels (u right, v up) of the point `p` of sphere `sphere` at time
    /// `t`, seen through `view`, to where it is one frame period later and earlier. A
    /// displacement that cannot be projected (the point on the camera's plane, a degenerate
    /// view) is 0.
    fn motion(&self, p: DVec3, sphere: u32, t: f64, view: &View) -> (DVec2, DVec2) {
        // A point of a cache moves on its line over the whole shot, as a sphere with a
        // velocity does.
        let at = |t: f64| match self.spheres.get(sphere as usize) {
            Some(s) => s.motion.at(t),
            None => match self.points.locate(sphere as usize - self.spheres.len()) {
                Some((set, i)) => set.at(i, t),
                None => DVec3::NAN,
            },
        };
        let centre = at(t);
        let here = view.project(p);
        let moved = |dt: f64| {
            let t2 = t + dt;
            // Spheres translate: the point keeps its offset from the centre.
            let p2 = at(t2) + (p - centre);
            let d = self.view_at(t2).project(p2) - here;
            // Image rows grow downward; v grows upward.
            let d = DVec2::new(d.x, -d.y);
            if d.is_finite() { d } else { DVec2::ZERO }
        };
        (moved(self.period), moved(-self.period))
    }
}

/// Whether `pass` divides by the hit count.
fn uses_hits(pass: Pass) -> bool {
    matches!(
        pass,
        Pass::Alpha | Pass::Depth | Pass::Normal | Pass::Motion
    )
}

#[inline]
fn add3(slots: &mut [f64], v: DVec3) {
    slots[0] += v.x;
    slots[1] += v.y;
    slots[2] += v.z;
}

/// A material's albedo as a denoiser takes it: glass is 1.
fn albedo(m: &Material) -> DVec3 {
    match *m {
        Material::Lambertian { albedo } | Material::Metal { albedo, .. } => albedo,
        Material::Dielectric { .. } => DVec3::ONE,
    }
}

/// The depth written where no sample hit.
pub const NO_DEPTH: f32 = 1e10;

/// Adds to `image` the channels of `passes` (whose sums `layout` keeps, or which need none),
/// made from a finished film laid out by `layout`: one channel per channel of each pass, in
/// [`Pass::ALL`]'s order, stored as each pass says ([`Pass::precision`]).
pub fn add_pass_channels(image: &mut Image, passes: PassSet, layout: &SumLayout, film: &Film) {
    let stride = layout.stride;
    assert_eq!(
        film.pass_stride(),
        stride,
        "the film keeps these passes' sums"
    );
    let names: Vec<(&'static str, Precision)> = passes
        .iter()
        .flat_map(|p| p.channels().iter().map(move |&n| (n, p.precision())))
        .collect();
    let n = film.width as usize * film.height as usize;
    let mut planes = vec![vec![0.0f32; n]; names.len()];
    for (rect, pixels, sums) in film.tiles_with_pass_sums() {
        for (i, pixel) in pixels.iter().enumerate() {
            let (x, y) = rect.position(i);
            let at = y as usize * film.width as usize + x as usize;
            let values = pixel_values(passes, layout, &sums[i * stride..(i + 1) * stride], pixel);
            for (plane, v) in planes.iter_mut().zip(values) {
                plane[at] = v;
            }
        }
    }
    for ((name, precision), plane) in names.into_iter().zip(planes) {
        image.set(name, precision, Values::Float(plane));
    }
}

/// A pixel's values of the channels of `passes`, in order, from its pass sums `slots` (laid
/// out by `layout`) and its colour's sums `pixel` (its samples, its mean as written, its
/// estimated variance of the mean). At most 21 values (every pass but the noisy colour's 3
/// and the samples' 1, with them).
fn pixel_values(passes: PassSet, layout: &SumLayout, slots: &[f64], pixel: &Pixel) -> [f32; 21] {
    let samples = pixel.taken();
    let hits = if layout.counts_hits {
        slots[layout.hits]
    } else {
        0.0
    };
    // Means over the hits: 0 where none hit.
    let over_hits = |s: f64| if hits > 0.0 { s / hits } else { 0.0 };
    let mut values: [f32; 21] = [0.0; 21];
    let mut k = 0;
    let mut push = |v: f64| {
        values[k] = v as f32;
        k += 1;
    };
    for pass in passes.iter() {
        match pass {
            Pass::Alpha => push(if samples > 0 {
                hits / samples as f64
            } else {
                0.0
            }),
            Pass::Depth => push(if hits > 0.0 {
                slots[layout.depth] / hits
            } else {
                NO_DEPTH as f64
            }),
            Pass::Normal => (0..3).for_each(|j| push(over_hits(slots[layout.normal + j]))),
            Pass::Albedo => (0..3).for_each(|j| {
                push(if samples > 0 {
                    slots[layout.albedo + j] / samples as f64
                } else {
                    0.0
                })
            }),
            Pass::Motion => (0..4).for_each(|j| push(over_hits(slots[layout.motion + j]))),
            Pass::Variance => {
                let variance = pixel.variance_of_mean();
                (0..3).for_each(|j| push(variance[j]));
            }
            Pass::Samples => push(samples as f64),
            Pass::Noisy => pixel.rgb_f32().iter().for_each(|&c| push(c as f64)),
        }
    }
    values
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_layout_holds_only_the_requested_sums() {
        assert_eq!(SumLayout::new(PassSet::EMPTY).stride, 0);
        assert_eq!(
            SumLayout::new(PassSet::EMPTY.with(Pass::Variance)).stride,
            0
        );
        assert_eq!(SumLayout::new(PassSet::EMPTY.with(Pass::Samples)).stride, 0);
        assert_eq!(SumLayout::new(PassSet::EMPTY.with(Pass::Alpha)).stride, 1);
        assert_eq!(SumLayout::new(PassSet::EMPTY.with(Pass::Albedo)).stride, 3);
        let all: PassSet = Pass::ALL.into_iter().collect();
        assert_eq!(SumLayout::new(all).stride, 1 + 1 + 3 + 3 + 4);
        let names: Vec<&str> = all
            .iter()
            .flat_map(|p| p.channels().iter().copied())
            .collect();
        assert_eq!(names.len(), 19);
    }

    #[test]
    fn means_divide_by_hits_or_by_samples() {
        let all: PassSet = Pass::ALL.into_iter().collect();
        let l = SumLayout::new(all);
        // Pixel 0: 4 samples, 2 hits at depths 1 and 3, albedo sums 2.
        let mut slots = vec![0.0; l.stride];
        slots[l.hits] = 2.0;
        slots[l.depth] = 4.0;
        slots[l.albedo] = 2.0;
        // Its colour: even samples 0, odd samples 2, so a mean of 1 and an estimated variance
        // of the mean of (0 - 2)^2 / (1/2 + 1/2) / 4 = 1.
        let mut colour = Pixel::default();
        for v in [0.0, 2.0, 0.0, 2.0] {
            colour.add(DVec3::splat(v));
        }
        let first = pixel_values(all, &l, &slots, &colour);
        // Pixel 1: no hit, 8 black samples.
        let mut black = Pixel::default();
        (0..8).for_each(|_| {
            black.add(DVec3::ZERO);
        });
        let second = pixel_values(all, &l, &vec![0.0; l.stride], &black);
        // The channels in Pass::ALL's order.
        let names: Vec<&str> = all
            .iter()
            .flat_map(|p| p.channels().iter().copied())
            .collect();
        let channel = |name: &str| {
            let k = names.iter().position(|n| *n == name).unwrap();
            [first[k], second[k]]
        };
        assert_eq!(channel("A"), [0.5, 0.0]);
        assert_eq!(channel("Z"), [2.0, NO_DEPTH]);
        assert_eq!(channel("albedo.R"), [0.5, 0.0]);
        assert_eq!(channel("N.X"), [0.0, 0.0]);
        assert_eq!(channel("variance.G"), [1.0, 0.0]);
        assert_eq!(channel("samples"), [4.0, 8.0]);
        assert_eq!(channel("noisy.B"), [1.0, 0.0]);
    }
}
