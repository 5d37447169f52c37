//! Memory: what a frame of a scene will hold (an estimate checked against the machine's
//! available memory before anything renders), and the process's peak, for `--stats`.

use raytrace_core::error::Error;
use raytrace_core::film::Pixel;
use raytrace_core::scene::Scene;
use raytrace_scene::point_cache::PointLoad;

/// Resident bytes of the process with a scene of a few spheres and no image to speak of:
/// code (the denoiser's library included), the thread pool, the allocator's arenas.
/// Measured: the peak of a 1x1 render of `scenes/quick.toml` (8.7 MiB since the binary holds
/// the GPU tracer too; 8.0 before).
const FLOOR_BYTES: u64 = 9 << 20;

/// Bytes per sphere while the scene file is read, beyond the [`Scene`] itself: the file's
/// text and its parsed form are gone once the scene is validated, but they set the peak of a
/// large scene. Calibrated on generated scenes of 10^4 to 10^6 spheres.
const LOAD_BYTES_PER_SPHERE: u64 = 300;

/// The bytes a frame of `scene` holds per pixel: the film's [`Pixel`] sums (40 bytes), which
/// an EXR file's colour is encoded from directly, with no copy; a PNG file's 8-bit copy (3
/// bytes, 4 with alpha); and with passes, their sums, their channels, the channels' copy as
/// encoded and the colour's (`f32` RGB).
pub(crate) fn bytes_per_pixel(scene: &Scene) -> u64 {
    use std::mem::size_of;
    let passes = scene.output.passes;
    let pass_channels: usize = passes.iter().map(|p| p.channels().len()).sum();
    let png = scene.output.format == raytrace_core::format::Format::Png;
    let encoded_copy = match (png, pass_channels) {
        (true, 0) => 3,
        (true, _) => 4,
        (false, 0) => 0,
        (false, _) => 3 * size_of::<f32>() as u64,
    };
    size_of::<Pixel>() as u64
        + encoded_copy
        + (raytrace_core::passes::SumLayout::new(passes).stride * size_of::<f64>()) as u64
        + (2 * pass_channels * size_of::<f32>()) as u64
}

/// An estimate of the most memory a render of one frame of `scene` at a time holds, in
/// bytes: the process's floor; per pixel, [`bytes_per_pixel`]; per sphere, the scene's
/// description, the shot's static geometry, one frame's prepared spheres with their boxes, a
/// hierarchy build's working arrays and the hierarchy, and the scene file while it is read;
/// per point of the frame's point caches (`load.points`), [`BYTES_PER_POINT`] (and with
/// `interpolate` [`INTERPOLATE_BYTES_PER_POINT`]), per point of the next snapshots
/// (`load.next`), [`NEXT_BYTES_PER_POINT`]; with point caches, what reading one of their
/// files holds ([`raytrace_scene::ply::READ_BUFFER_BYTES`]); on the GPU, what its path adds
/// ([`raytrace_gpu::frame_bytes`]: the driver, the scene's words, the film on the device and
/// its read-back buffers, counted on the host, where a software device keeps them). It grows
/// linearly in pixels, spheres and points, and errs high for scenes whose spheres are mostly
/// still.
pub fn memory_estimate(scene: &Scene, load: PointLoad) -> u64 {
    use std::mem::size_of;
    let pixels = scene.output.width as u64 * scene.output.height as u64;
    let per_pixel = bytes_per_pixel(scene);
    let n = scene.spheres.len() as u64;
    // Keyframed paths hold their keys in the description and again in each frame's path.
    let keys: u64 = scene
        .spheres
        .iter()
        .map(|s| match &s.motion {
            raytrace_core::motion::Motion::Keyframes(k) => k.len() as u64,
            _ => 0,
        })
        .sum();
    let per_sphere = size_of::<raytrace_core::sphere::SphereDesc>()
        + size_of::<raytrace_core::sphere::PreparedSphere>()
        // A frame's boxes at the shutter's opening and closing, and a build's copy of each
        // with its centroid (the build takes the union, then the per-leaf boxes).
        + 2 * size_of::<raytrace_core::aabb::Aabb>()
        + raytrace_core::world::PRIM_BYTES
        + raytrace_core::bvh::BUILD_BYTES_PER_PRIMITIVE
        + raytrace_core::bvh::BYTES_PER_PRIMITIVE;
    // A point cache's file is read through bounded buffers, one file at a time.
    let reading = match scene.points.is_empty() {
        true => 0,
        false => raytrace_scene::ply::READ_BUFFER_BYTES,
    };
    let gpu = match scene.render.device {
        raytrace_core::scene::Device::Gpu => {
            let read = crate::finish::passes_read(scene);
            let kept = raytrace_core::passes::SumLayout::keeping(scene.output.passes, read);
            raytrace_gpu::frame_bytes(scene, kept.stride)
        }
        raytrace_core::scene::Device::Cpu => 0,
    };
    FLOOR_BYTES
        + gpu
        + reading
        + pixels * per_pixel
        + n * (per_sphere as u64 + LOAD_BYTES_PER_SPHERE)
        + keys * 2 * size_of::<raytrace_core::motion::Key>() as u64
        + load.bytes(scene)
}

/// The memory a render of `scene` needs with `points` points in its largest frame
/// ([`memory_estimate`]), or, if that is more than the machine has available (Linux:
/// `MemAvailable`; elsewhere not checked), a usage error that names the scene file and says
/// what to lower.
pub fn check_memory(scene: &Scene, load: PointLoad) -> Result<u64, Error> {
    let estimate = memory_estimate(scene, load);
    let points = load.points + load.next;
    let with_points = if points > 0 {
        format!(" and {points} points")
    } else {
        String::new()
    };
    match available_memory_bytes() {
        Some(available) if estimate > available => Err(Error::Usage(format!(
            "{}: a frame of {}x{} pixels with {} spheres{with_points} needs about {} of memory, and {} is available: lower --width/--height or use fewer spheres",
            raytrace_core::error::elide_path(&scene.source),
            scene.output.width,
            scene.output.height,
            scene.spheres.len(),
            mib(estimate),
            mib(available)
        ))),
        _ => Ok(estimate),
    }
}

/// Bytes in MiB, as `12.3 MiB`.
pub fn mib(bytes: u64) -> String {
    format!("{:.1} MiB", bytes as f64 / 1048576.0)
}

/// The memory available to a new process (Linux: `MemAvailable` in `/proc/meminfo`).
fn available_memory_bytes() -> Option<u64> {
    proc_bytes("/proc/meminfo", "MemAvailable:")
}

/// A figure in kB from a Linux `/proc` file (`KEY: N kB`), in bytes.
fn proc_bytes(file: &str, key: &str) -> Option<u64> {
    let text = std::fs::read_to_string(file).ok()?;
    let line = text.lines().find(|l| l.starts_with(key))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    kib.checked_mul(1024)
}

/// The process's peak resident memory so far (Linux: `VmHWM` in `/proc/self/status`).
pub fn peak_memory_bytes() -> Option<u64> {
    proc_bytes("/proc/self/status", "VmHWM:")
}

#[cfg(test)]
mod tests {
    use super::*;
    use raytrace_scene::scene_file::SceneFile;

    #[test]
    fn the_memory_estimate_grows_linearly_with_pixels_and_spheres() {
        let scene = |w: u32, h: u32, spheres: usize| {
            let mut text = format!("[output]\nwidth = {w}\nheight = {h}\n");
            for i in 0..spheres {
                text += &format!(
                    "[[sphere]]\ncenter = [{i}.0, 0.0, 0.0]\nradius = 0.5\nvelocity = [0.0, 1.0, 0.0]\nmaterial = {{ type = \"lambertian\", albedo = [0.5, 0.5, 0.5] }}\n"
                );
            }
            memory_estimate(
                &Scene::parse(&text, std::path::Path::new("m.toml")).unwrap(),
                0.into(),
            )
        };
        let base = scene(100, 100, 10);
        let pixels = scene(200, 100, 10) - base;
        assert_eq!(scene(300, 100, 10) - base, 2 * pixels);
        let spheres = scene(100, 100, 20) - base;
        assert!(spheres > 0);
        assert_eq!(scene(100, 100, 30) - base, 2 * spheres);
        // 2^32 pixels need 160 GiB: 40 bytes each, the film alone.
        assert!(scene(65536, 65536, 1) > 160 << 30);
        let png = Scene::parse("", std::path::Path::new("m.toml")).unwrap();
        assert!(png.output.path.ends_with(".png"));
        assert_eq!(pixels, 100 * 100 * bytes_per_pixel(&png));
        assert_eq!(bytes_per_pixel(&png), 43);
    }

    #[test]
    fn passes_take_memory_only_when_requested() {
        let scene = |passes: &str| {
            let text = format!(
                "[output]\npath = \"o.exr\"\nwidth = 20\nheight = 10\npasses = {passes}\n[render]\nsamples = 2\n"
            );
            Scene::parse(&text, std::path::Path::new("p.toml")).unwrap()
        };
        let (none, alpha, all) = (
            scene("[]"),
            scene("[\"alpha\"]"),
            scene("[\"alpha\", \"depth\", \"normal\", \"albedo\", \"motion\", \"variance\"]"),
        );
        let pixels = 200;
        // The film alone, its colour encoded with no copy.
        assert_eq!(bytes_per_pixel(&none), 40);
        // Alpha: one sum and one channel (and its copy as written) per pixel, and the
        // colour's copy as written beside it.
        assert_eq!(
            memory_estimate(&alpha, 0.into()) - memory_estimate(&none, 0.into()),
            pixels * (8 + 2 * 4 + 12)
        );
        assert_eq!(
            memory_estimate(&all, 0.into()) - memory_estimate(&none, 0.into()),
            pixels * (12 * 8 + 2 * 15 * 4 + 12)
        );
        let statics = raytrace_core::renderer::CpuShot::new(&none);
        let r = raytrace_core::renderer::FrameJob::new(&none, 1)
            .sample(&statics)
            .unwrap();
        // The colour alone.
        assert_eq!(r.image.channels().len(), 3);
        let statics = raytrace_core::renderer::CpuShot::new(&all);
        let r = raytrace_core::renderer::FrameJob::new(&all, 1)
            .sample(&statics)
            .unwrap();
        // The colour and the passes' 15 channels.
        assert_eq!(r.image.channels().len(), 3 + 15);
    }
}
