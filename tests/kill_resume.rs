//! Interrupted and failing renders: a render killed mid-frame leaves only complete frames,
//! `--skip-existing` renders just the missing ones and the result is bit-identical to an
//! uninterrupted render; a folder that cannot be written to fails the run with exit status
//! 1 and the path, leaving earlier frames intact and no partial files.

use std::fs;
use std::io::Write;
use std::os::unix::fs::PermissionsExt;
use std::os::unix::process::ExitStatusExt;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant, SystemTime};

const BIN: &str = env!("CARGO_BIN_EXE_raytrace");
const WIDTH: usize = 64;
const HEIGHT: usize = 36;

/// A shot of `frames` frames at 64x36 with `samples` samples per pixel.
fn shot(frames: u32, samples: u32) -> String {
    format!(
        r#"
[shot]
fps = 24.0
frames = {frames}
first_frame = 1
shutter_angle = 180.0

[output]
path = "out/shot_####.exr"
width = {WIDTH}
height = {HEIGHT}

[render]
samples = {samples}
max_depth = 16
seed = 11

[camera]
look_from = [0.0, 1.2, 5.0]
look_at = [0.0, 0.5, 0.0]
vfov = 40.0
aperture = 0.05

[materials]
ground = {{ type = "lambertian", albedo = [0.5, 0.5, 0.5] }}
red = {{ type = "lambertian", albedo = [0.7, 0.2, 0.1] }}
glass = {{ type = "dielectric", ior = 1.5 }}
steel = {{ type = "metal", albedo = [0.8, 0.8, 0.8], fuzz = 0.2 }}

[[sphere]]
center = [0.0, -1000.0, 0.0]
radius = 1000.0
material = "ground"

[[sphere]]
center = [0.0, 0.5, 0.0]
radius = 0.5
material = "glass"

[[sphere]]
center = [-1.1, 0.5, -0.5]
radius = 0.5
material = "steel"

[[sphere]]
center = [1.0, 0.35, 0.6]
radius = 0.35
material = "red"
velocity = [-1.5, 0.0, 0.0]
"#
    )
}

fn text(o: &Output) -> String {
    format!(
        "status {}\nstdout:\n{}stderr:\n{}",
        o.status,
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}

/// Prints and runs the binary in `dir` (bounded to two minutes).
fn run(dir: &Path, args: &[&str]) -> Output {
    let mut cmd = Command::new(BIN);
    cmd.args(args).current_dir(dir);
    println!("$ {cmd:?}");
    let mut child = cmd
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("run raytrace");
    // Drain the pipes on threads so a chatty child cannot block on a full pipe.
    let mut so = child.stdout.take().unwrap();
    let mut se = child.stderr.take().unwrap();
    let out = std::thread::spawn(move || {
        let mut v = Vec::new();
        std::io::Read::read_to_end(&mut so, &mut v).map(|_| v)
    });
    let err = std::thread::spawn(move || {
        let mut v = Vec::new();
        std::io::Read::read_to_end(&mut se, &mut v).map(|_| v)
    });
    let deadline = Instant::now() + Duration::from_secs(120);
    let status = loop {
        if let Some(status) = child.try_wait().unwrap() {
            break status;
        }
        if Instant::now() > deadline {
            let _ = child.kill();
            let _ = child.wait();
            panic!("raytrace {args:?} did not finish within 120 s");
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    let o = Output {
        status,
        stdout: out.join().unwrap().unwrap(),
        stderr: err.join().unwrap().unwrap(),
    };
    print!("{}", String::from_utf8_lossy(&o.stdout));
    eprint!("{}", String::from_utf8_lossy(&o.stderr));
    o
}

/// The frame files (`shot_NNNN.exr`) and the hidden temporary files (`.shot_NNNN.exr.*.tmp`)
/// in `dir`; anything else there fails the test.
fn listing(dir: &Path) -> (Vec<u32>, Vec<PathBuf>) {
    let mut frames = Vec::new();
    let mut temps = Vec::new();
    let Ok(entries) = fs::read_dir(dir) else {
        return (frames, temps);
    };
    for e in entries {
        let e = e.unwrap();
        let name = e.file_name().to_string_lossy().into_owned();
        if name.starts_with(".shot_") && name.ends_with(".tmp") {
            temps.push(e.path());
        } else if let Some(n) = name
            .strip_prefix("shot_")
            .and_then(|r| r.strip_suffix(".exr"))
            .filter(|n| n.len() == 4)
            .and_then(|n| n.parse().ok())
        {
            frames.push(n);
        } else {
            panic!("unexpected file {} in {}", name, dir.display());
        }
    }
    frames.sort();
    temps.sort();
    (frames, temps)
}

fn frame_path(dir: &Path, frame: u32) -> PathBuf {
    dir.join(format!("shot_{frame:04}.exr"))
}

/// Reads a frame back with the `exr` crate: it must decode, be 64x36 with R, G, B channels
/// of finite values.
fn assert_valid_exr(path: &Path) {
    use exr::prelude::*;
    let image = read_all_flat_layers_from_file(path)
        .unwrap_or_else(|e| panic!("{} is not a complete EXR file: {e}", path.display()));
    assert_eq!(image.layer_data.len(), 1, "{}", path.display());
    let layer = &image.layer_data[0];
    assert_eq!(
        (layer.size.width(), layer.size.height()),
        (WIDTH, HEIGHT),
        "{}",
        path.display()
    );
    let names: Vec<String> = layer
        .channel_data
        .list
        .iter()
        .map(|c| c.name.to_string())
        .collect();
    for want in ["R", "G", "B"] {
        assert!(
            names.iter().any(|n| n == want),
            "{}: channels {names:?}",
            path.display()
        );
    }
    for c in &layer.channel_data.list {
        assert!(
            c.sample_data.values_as_f32().all(f32::is_finite),
            "{}: non-finite values",
            path.display()
        );
    }
}

/// The frame numbers in `frame N: ...` lines of a run's stdout: (rendered, skipped).
fn frame_lines(stdout: &str) -> (Vec<u32>, Vec<u32>) {
    let mut rendered = Vec::new();
    let mut skipped = Vec::new();
    for line in stdout.lines() {
        let Some((n, rest)) = line.strip_prefix("frame ").and_then(|r| r.split_once(": ")) else {
            continue;
        };
        let n: u32 = n.parse().unwrap_or_else(|_| panic!("bad line {line:?}"));
        if rest.ends_with(" exists, skipped") {
            skipped.push(n);
        } else {
            rendered.push(n);
        }
    }
    (rendered, skipped)
}

#[test]
fn killed_render_resumes_to_identical_frames() {
    const FRAMES: u32 = 6;
    let tmp = tempfile::tempdir().unwrap();
    let root = tmp.path();
    fs::write(root.join("shot.toml"), shot(FRAMES, 3072)).unwrap();
    let out = root.join("out");

    // Start the render and kill it (SIGKILL) as soon as its first frame is on disk, that is
    // while it is busy with the next one.
    let mut cmd = Command::new(BIN);
    cmd.args(["render", "shot.toml", "--threads", "1"])
        .current_dir(root);
    println!("$ {cmd:?} &");
    let log = root.join("killed.log");
    let mut child = cmd
        .stdout(fs::File::create(&log).unwrap())
        .stderr(Stdio::inherit())
        .spawn()
        .expect("start raytrace");
    let pid = child.id();
    let start = Instant::now();
    loop {
        if !listing(&out).0.is_empty() {
            break;
        }
        if let Some(status) = child.try_wait().unwrap() {
            panic!("render ended ({status}) before its first frame appeared");
        }
        if start.elapsed() > Duration::from_secs(120) {
            let _ = child.kill();
            let _ = child.wait();
            panic!("no frame within 120 s");
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    child.kill().unwrap();
    let status = child.wait().unwrap();
    println!(
        "killed pid {pid} after {:.2} s: {status}",
        start.elapsed().as_secs_f64()
    );
    assert_eq!(
        status.signal(),
        Some(9),
        "the render was not killed: {status}"
    );

    let (present, temps) = listing(&out);
    println!("after the kill: frames {present:?}, temporary files {temps:?}");
    assert!(
        !present.is_empty() && present.len() < FRAMES as usize,
        "need an interrupted render, got frames {present:?}; make frames slower"
    );
    // Frames are written in order, so what exists is a prefix of the shot.
    assert_eq!(present, (1..=present.len() as u32).collect::<Vec<_>>());
    for &f in &present {
        assert_valid_exr(&frame_path(&out, f));
    }
    let before: Vec<Vec<u8>> = present
        .iter()
        .map(|&f| fs::read(frame_path(&out, f)).unwrap())
        .collect();

    // What a kill in the middle of writing leaves: a hidden temporary file of the dead
    // process. The next run for that target removes it once it is older than a minute (the
    // guard for folders shared between machines), so age it, and any real leftover, by two
    // minutes as if the resume ran later.
    let planted = out.join(format!(".shot_{FRAMES:04}.exr.{pid}.00000000deadbeef.tmp"));
    fs::write(&planted, b"partial frame").unwrap();
    let old = SystemTime::now() - Duration::from_secs(120);
    for t in temps.iter().chain([&planted]) {
        fs::File::options()
            .write(true)
            .open(t)
            .and_then(|f| f.set_modified(old))
            .unwrap();
    }
    let (frames_now, _) = listing(&out);
    assert_eq!(
        frames_now, present,
        "a temporary file was taken for a frame"
    );

    // Resume.
    let o = run(root, &["render", "shot.toml", "--skip-existing"]);
    assert!(o.status.success(), "{}", text(&o));
    let (rendered, skipped) = frame_lines(&String::from_utf8_lossy(&o.stdout));
    let missing: Vec<u32> = (1..=FRAMES).filter(|f| !present.contains(f)).collect();
    assert_eq!(skipped, present, "skipped frames\n{}", text(&o));
    assert_eq!(rendered, missing, "rendered frames\n{}", text(&o));
    let (after, temps_after) = listing(&out);
    assert_eq!(after, (1..=FRAMES).collect::<Vec<_>>());
    assert!(
        temps_after.is_empty(),
        "temporary files left: {temps_after:?}"
    );
    for (&f, bytes) in present.iter().zip(&before) {
        assert!(
            fs::read(frame_path(&out, f)).unwrap() == *bytes,
            "frame {f} changed on resume"
        );
    }

    // The same shot, uninterrupted and on all cores, into another folder: same bits.
    let o = run(
        root,
        &["render", "shot.toml", "--output", "ref/shot_####.exr"],
    );
    assert!(o.status.success(), "{}", text(&o));
    for f in 1..=FRAMES {
        let a = fs::read(frame_path(&out, f)).unwrap();
        let b = fs::read(frame_path(&root.join("ref"), f)).unwrap();
        assert!(
            a == b,
            "frame {f}: the resumed render differs from the uninterrupted one"
        );
    }
}

/// Unmounts a tmpfs when dropped.
struct Mount(PathBuf);

impl Drop for Mount {
    fn drop(&mut self) {
        let ok = Command::new("umount")
            .arg(&self.0)
            .status()
            .is_ok_and(|s| s.success());
        if !ok {
            let _ = Command::new("umount").arg("-l").arg(&self.0).status();
        }
    }
}

/// Restores a folder's permissions when dropped (so the temporary folder can be removed).
struct Unlock(PathBuf);

impl Drop for Unlock {
    fn drop(&mut self) {
        let _ = fs::set_permissions(&self.0, fs::Permissions::from_mode(0o755));
    }
}

fn can_create_file_in(dir: &Path) -> bool {
    let probe = dir.join(".probe");
    match fs::File::create(&probe) {
        Ok(_) => {
            let _ = fs::remove_file(&probe);
            true
        }
        Err(_) => false,
    }
}

/// Renders frame 1 into `dir`, makes further writes there fail with `make_unwritable`, then
/// renders frames 1-2 into it: exit status 1, the message names the path, frame 1 is
/// unchanged, and there is no frame 2 and no temporary file.
fn assert_failed_write_is_clean(root: &Path, dir: &Path, make_unwritable: impl FnOnce()) {
    let pattern = format!("{}/shot_####.exr", dir.display());
    let o = run(
        root,
        &["render", "shot.toml", "--frames", "1", "--output", &pattern],
    );
    assert!(o.status.success(), "{}", text(&o));
    let first = fs::read(frame_path(dir, 1)).unwrap();
    make_unwritable();

    let o = run(
        root,
        &[
            "render",
            "shot.toml",
            "--frames",
            "1-2",
            "--output",
            &pattern,
        ],
    );
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(
        stderr.contains(&dir.join("shot_0001.exr").display().to_string()),
        "the message does not name the path:\n{}",
        text(&o)
    );
    assert!(
        fs::read(frame_path(dir, 1)).unwrap() == first,
        "frame 1 changed"
    );
    let (frames, temps) = listing(dir);
    assert_eq!(frames, vec![1], "frames in {}", dir.display());
    assert!(temps.is_empty(), "temporary files left: {temps:?}");
}

#[test]
fn unwritable_folder_fails_cleanly() {
    let tmp = tempfile::tempdir().unwrap();
    let root = tmp.path();
    fs::write(root.join("shot.toml"), shot(2, 2)).unwrap();

    // A read-only folder: enough for an ordinary user.
    let ro = root.join("readonly");
    fs::create_dir(&ro).unwrap();
    fs::set_permissions(&ro, fs::Permissions::from_mode(0o555)).unwrap();
    let _unlock = Unlock(ro.clone());
    if !can_create_file_in(&ro) {
        fs::set_permissions(&ro, fs::Permissions::from_mode(0o755)).unwrap();
        assert_failed_write_is_clean(root, &ro, || {
            fs::set_permissions(&ro, fs::Permissions::from_mode(0o555)).unwrap();
        });
        println!("read-only folder: checked");
        return;
    }

    // Permissions do not stop this user (root): use a full disk instead, a tiny tmpfs.
    println!("read-only folder: still writable (running as root), trying a full tmpfs");
    let full = root.join("full");
    fs::create_dir(&full).unwrap();
    let mut cmd = Command::new("mount");
    cmd.args(["-t", "tmpfs", "-o", "size=64k", "tmpfs"])
        .arg(&full);
    println!("$ {cmd:?}");
    match cmd.output() {
        Ok(o) if o.status.success() => {}
        Ok(o) => {
            println!(
                "skipped: unwritable-folder check: neither permissions nor a tmpfs mount can make a folder unwritable here (mount: {})",
                String::from_utf8_lossy(&o.stderr).trim()
            );
            return;
        }
        Err(e) => {
            println!(
                "skipped: unwritable-folder check: permissions do not apply and mount cannot run: {e}"
            );
            return;
        }
    }
    let _mount = Mount(full.clone());
    let frames = full.join("frames");
    fs::create_dir(&frames).unwrap();
    assert_failed_write_is_clean(root, &frames, || {
        // Fill the file system to the last byte.
        let mut filler = fs::File::create(full.join("filler")).unwrap();
        let block = vec![0x55u8; 4096];
        let mut total = 0usize;
        loop {
            match filler.write(&block) {
                Ok(0) => break,
                Ok(n) => total += n,
                Err(e) => {
                    assert_eq!(e.raw_os_error(), Some(28), "filling the tmpfs: {e}");
                    break;
                }
            }
        }
        let _ = filler.sync_all();
        println!("filled the tmpfs with {total} bytes");
    });
    println!("full disk: checked");
}
