//! Memory: what a frame of a scene will hold (an estimate checked against the machine's
//! available memory before anything renders), and the process's peak, for `--stats`.

use crate::finish;
use raytrace_core::error::Error;
use raytrace_core::passes::SumLayout;
use raytrace_core::renderer::FrameResult;
use raytrace_core::scene::{Device, Scene};
use raytrace_core::world;
use raytrace_scene::point_cache::PointLoad;

/// Resident bytes of the process with a scene of a few spheres and no image to speak of:
/// code (the denoiser's library included), the thread pool, the allocator's arenas.
/// Measured: the peak of a 1x1 render of `scenes/quick.toml` (8.7 MiB since the binary holds
/// the GPU tracer too; 8.0 before).
const FLOOR_BYTES: u64 = 9 << 20;

/// An estimate of the most memory a render of one frame of `scene` at a time holds, in
/// bytes: the sum of what each room that holds memory says it holds for it (so that a buffer
/// is counted where it is allocated):
/// - the process's floor (`FLOOR_BYTES`);
/// - the scene file while it is read ([`raytrace_scene::scene_file::bytes_for`]) and the
///   spheres, described, prepared and in their hierarchies ([`world::bytes_for`]);
/// - the frame's points and the reading of their files ([`PointLoad::bytes`]: `load` is the
///   most points a frame holds, its own and the next snapshots'; with a part of a file's
///   rows for each thread of the pool it is called in);
/// - the sampled frame, its film and its image ([`FrameResult::bytes_for`], with the passes
///   its finishing reads);
/// - its finishing ([`finish::bytes_for`]: denoising, history);
/// - its encoding ([`raytrace_io::bytes_for`]);
/// - with points on the CPU, each worker thread's stack under its batch of paths in turns
///   ([`raytrace_core::tracer::TURNS_STACK_BYTES`]), for the threads of the pool it is called
///   in: call it where the frame renders (outside any pool, rayon's default: one thread a
///   core, or `RAYON_NUM_THREADS`); counted for any points, though points of less than 16
///   MiB walk alone (`TracedPoints::walk_in_turns`), where it errs high by that stack;
/// - on the GPU, what its path adds ([`raytrace_gpu::frame_bytes`]: the driver, the scene's
///   words with the frame's points, the film on the device and its read-back buffers, counted
///   on the host, where a software device keeps them).
///
/// It grows linearly in pixels, spheres and points (OIDN's scratch memory, at most 2.5
/// GiB, aside), and errs high for scenes whose spheres are mostly still.
pub fn memory_estimate(scene: &Scene, load: PointLoad) -> u64 {
    let pixels = scene.output.width as u64 * scene.output.height as u64;
    let layout = SumLayout::keeping(scene.output.passes, finish::passes_read(scene));
    let gpu = match scene.render.device {
        Device::Gpu => raytrace_gpu::frame_bytes(scene, load.points, layout.stride),
        Device::Cpu => 0,
    };
    FLOOR_BYTES
        + raytrace_scene::scene_file::bytes_for(scene)
        + world::bytes_for(scene)
        + load.bytes(scene)
        + FrameResult::bytes_for(scene, &layout)
        + finish::bytes_for(scene)
        + raytrace_io::bytes_for(scene.output.format, pixels, scene.output.passes)
        + gpu
        + turns_stacks(scene)
}

/// The worker threads' stacks under their batches of paths in turns: a frame with points
/// traced on the CPU, by the threads of the pool this is called in.
fn turns_stacks(scene: &Scene) -> u64 {
    if scene.points.is_empty() || scene.render.device == Device::Gpu {
        return 0;
    }
    rayon::current_num_threads() as u64 * raytrace_core::tracer::TURNS_STACK_BYTES
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
    use raytrace_core::scene::Carry;
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
        // A pixel of a PNG frame: the film's sums (40), the image's colour (12) and its 8-bit
        // encoding (3).
        assert_eq!(pixels, 100 * 100 * (40 + 12 + 3));
    }

    /// With points, each worker of the pool the estimate is made in adds the part of a
    /// file's rows it reads, and on the CPU its stack under a batch of paths; without points
    /// the threads add nothing.
    #[test]
    fn the_workers_stacks_are_those_of_the_pool_the_frame_renders_in() {
        let in_pool = |threads: usize, text: &str| {
            let scene = Scene::parse(text, std::path::Path::new("m.toml")).unwrap();
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            pool.install(|| memory_estimate(&scene, 1000.into()))
        };
        let points = "[[points]]\nfile = \"p_#.ply\"\nmaterial = { type = \"lambertian\", albedo = [0.5, 0.5, 0.5] }\n";
        let stack = raytrace_core::tracer::TURNS_STACK_BYTES;
        let part = PointLoad::READ_BYTES_PER_THREAD;
        assert!(stack > 0 && part > 0);
        assert_eq!(in_pool(3, points) - in_pool(1, points), 2 * (stack + part));
        assert_eq!(in_pool(5, points) - in_pool(1, points), 4 * (stack + part));
        let gpu = format!("{points}[render]\ndevice = \"gpu\"\n");
        assert_eq!(in_pool(3, &gpu) - in_pool(1, &gpu), 2 * part);
        assert_eq!(in_pool(3, ""), in_pool(1, ""));
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
        let layout = |s: &Scene| SumLayout::new(s.output.passes);
        // The film and the colour, encoded with no copy.
        assert_eq!(
            FrameResult::bytes_for(&none, &layout(&none)),
            pixels * (40 + 12)
        );
        assert_eq!(
            raytrace_io::bytes_for(none.output.format, pixels, none.output.passes),
            0
        );
        // Alpha: one sum and one channel per pixel, and its copy as encoded (half) beside the
        // colour's (float).
        assert_eq!(
            memory_estimate(&alpha, 0.into()) - memory_estimate(&none, 0.into()),
            pixels * (8 + 4 + 2 + 12)
        );
        // Every pass: 12 sums, 15 channels, their copies as encoded (7 half, 8 float) and the
        // colour's.
        assert_eq!(
            memory_estimate(&all, 0.into()) - memory_estimate(&none, 0.into()),
            pixels * (12 * 8 + 15 * 4 + 7 * 2 + 8 * 4 + 12)
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

    #[test]
    fn denoising_and_history_are_counted() {
        use raytrace_scene::scene_file::Overrides;
        let scene = |denoise: Option<bool>, temporal: Option<bool>| {
            let text = "[output]\nwidth = 200\nheight = 100\n";
            let finish = Overrides {
                denoise,
                temporal,
                ..Overrides::default()
            };
            Scene::parse_with(text, std::path::Path::new("d.toml"), &finish).unwrap()
        };
        let raw = memory_estimate(&scene(None, None), 0.into());
        let denoised = memory_estimate(&scene(Some(true), None), 0.into());
        // --temporal samples differently and finishes as --denoise does, holding the frame
        // before's change terms for its stated flicker.
        let temporal = memory_estimate(&scene(Some(true), Some(true)), 0.into());
        let mut historic = scene(Some(true), None);
        historic.output.denoise.as_mut().unwrap().carry = Carry::Written;
        let history = memory_estimate(&historic, 0.into());
        // OIDN's scratch alone is 355 bytes a pixel at the default quality.
        assert!(denoised - raw > 200 * 100 * 355, "{raw} {denoised}");
        let held = raytrace_denoise::change::ChangeTerms::bytes_for(200 * 100);
        assert_eq!(temporal, denoised + held);
        assert!(history > denoised);
        assert_eq!(finish::bytes_for(&scene(None, None)), 0);
    }
}
