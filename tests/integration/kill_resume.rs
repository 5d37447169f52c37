//! Interrupted and failing renders: a render killed mid-frame leaves only complete frames,
//! `--skip-existing` renders just the missing ones (and those whose file is incomplete) and
//! the result is bit-identical to an uninterrupted render; SIGINT and SIGTERM stop a render
//! with exit status 130 and 143, no temporary file and every finished frame; a write that
//! fails half way (a full file system, a file size limit) fails the run with exit status 1
//! and the path, leaving earlier frames intact and no partial files.

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

/// This machine's name as temporary file names record it (letters, digits and `-`).
fn host() -> String {
    let raw = fs::read_to_string("/proc/sys/kernel/hostname").expect("the host name");
    raw.trim()
        .chars()
        .take(63)
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '-' })
        .collect()
}

/// Reads a frame back with the `exr` crate: it must decode, be 64x36 with R, G, B channels
/// of finite values.
fn assert_valid_exr(path: &Path) {
    assert_valid_exr_of(path, WIDTH, HEIGHT)
}

/// [`assert_valid_exr`] for a frame of `width` x `height`.
fn assert_valid_exr_of(path: &Path, width: usize, height: usize) {
    use exr::prelude::*;
    let image = read_all_flat_layers_from_file(path)
        .unwrap_or_else(|e| panic!("{} is not a complete EXR file: {e}", path.display()));
    assert_eq!(image.layer_data.len(), 1, "{}", path.display());
    let layer = &image.layer_data[0];
    assert_eq!(
        (layer.size.width(), layer.size.height()),
        (width, height),
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
    // process, named with this machine's name. The next run for that target removes it at
    // once, since its writer is gone. Files of other machines (a shared folder) are removed
    // only once they are a minute old: one just written stays, an old one goes.
    let host = host();
    let planted = out.join(format!(
        ".shot_{FRAMES:04}.exr.{host}.{pid}.00000000deadbeef.tmp"
    ));
    fs::write(&planted, b"partial frame").unwrap();
    let other = if host == "farm-node-2" {
        "farm-node-3"
    } else {
        "farm-node-2"
    };
    let other_young = out.join(format!(
        ".shot_{FRAMES:04}.exr.{other}.{pid}.00000000cafe0001.tmp"
    ));
    let other_old = out.join(format!(
        ".shot_{FRAMES:04}.exr.{other}.1.00000000cafe0002.tmp"
    ));
    fs::write(&other_young, b"another machine's frame").unwrap();
    fs::write(&other_old, b"another machine's frame").unwrap();
    fs::File::options()
        .write(true)
        .open(&other_old)
        .and_then(|f| f.set_modified(SystemTime::now() - Duration::from_secs(120)))
        .unwrap();
    // A frame file that is there but empty (as a copy that failed leaves): not a frame.
    let last = present.len() as u32 + 1;
    let empty = last < FRAMES;
    if empty {
        fs::write(frame_path(&out, last), b"").unwrap();
    }
    let (frames_now, _) = listing(&out);
    let mut want = present.clone();
    if empty {
        want.push(last);
    }
    assert_eq!(frames_now, want, "a temporary file was taken for a frame");

    // Resume.
    let o = run(root, &["render", "shot.toml", "--skip-existing"]);
    assert!(o.status.success(), "{}", text(&o));
    let stdout = String::from_utf8_lossy(&o.stdout);
    let (rendered, skipped) = frame_lines(&stdout);
    let missing: Vec<u32> = (1..=FRAMES).filter(|f| !present.contains(f)).collect();
    assert_eq!(skipped, present, "skipped frames\n{}", text(&o));
    assert_eq!(rendered, missing, "rendered frames\n{}", text(&o));
    if empty {
        assert!(
            stdout.contains(&format!("(0 bytes): frame {last} is rendered again")),
            "{}",
            text(&o)
        );
    }
    let (after, temps_after) = listing(&out);
    assert_eq!(after, (1..=FRAMES).collect::<Vec<_>>());
    assert_eq!(
        temps_after,
        vec![other_young],
        "only the young file of another machine may stay"
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

/// Renders frame 1 into `dir`, then renders frames 1-2 into it with `wrap` around the
/// command (after `make_unwritable` ran): exit status 1, the message names the path, frame 1
/// is unchanged, and there is no frame 2 and no temporary file.
fn assert_failed_write_is_clean(
    root: &Path,
    dir: &Path,
    make_unwritable: impl FnOnce(),
    wrap: &[&str],
) -> String {
    let pattern = format!("{}/shot_####.exr", dir.display());
    let o = run(
        root,
        &["render", "shot.toml", "--frames", "1", "--output", &pattern],
    );
    assert!(o.status.success(), "{}", text(&o));
    let first = fs::read(frame_path(dir, 1)).unwrap();
    make_unwritable();

    let mut args: Vec<&str> = wrap.to_vec();
    if !wrap.is_empty() {
        args.push(BIN);
    }
    args.extend([
        "render",
        "shot.toml",
        "--frames",
        "1-2",
        "--output",
        &pattern,
    ]);
    let o = if wrap.is_empty() {
        run(root, &args)
    } else {
        run_program(wrap[0], root, &args[1..])
    };
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    let stderr = String::from_utf8_lossy(&o.stderr).into_owned();
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
    stderr
}

/// Runs `program` with `args` in `dir`, bounded to two minutes.
fn run_program(program: &str, dir: &Path, args: &[&str]) -> Output {
    let mut cmd = Command::new(program);
    cmd.args(args).current_dir(dir);
    println!("$ {cmd:?}");
    let child = cmd
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("run");
    let start = Instant::now();
    let o = child.wait_with_output().unwrap();
    assert!(start.elapsed() < Duration::from_secs(120));
    print!("{}", String::from_utf8_lossy(&o.stdout));
    eprint!("{}", String::from_utf8_lossy(&o.stderr));
    o
}

#[test]
fn a_write_past_the_file_size_limit_fails_cleanly() {
    // `ulimit -f` (as a scheduler may set): the frame's write fails half way with EFBIG. The
    // process is not killed by SIGXFSZ: it removes its temporary file and exits 1. This
    // holds for root too.
    let tmp = tempfile::tempdir().unwrap();
    let root = tmp.path();
    fs::write(root.join("shot.toml"), shot(2, 2)).unwrap();
    let dir = root.join("frames");
    let stderr = assert_failed_write_is_clean(
        root,
        &dir,
        || {},
        // 4 blocks of 512 bytes: the frame (about 20 kB) does not fit.
        &["sh", "-c", "ulimit -f 4 && exec \"$0\" \"$@\""],
    );
    assert!(stderr.contains("File too large"), "{stderr}");
}

#[test]
fn a_full_file_system_fails_cleanly() {
    let tmp = tempfile::tempdir().unwrap();
    let root = tmp.path();
    fs::write(root.join("shot.toml"), shot(2, 2)).unwrap();

    // A tiny tmpfs filled to the last byte: the frame's write fails half way with ENOSPC.
    // Needs `mount` (root, or a user allowed to mount).
    let full = root.join("full");
    fs::create_dir(&full).unwrap();
    let mut cmd = Command::new("mount");
    cmd.args(["-t", "tmpfs", "-o", "size=64k", "tmpfs"])
        .arg(&full);
    println!("$ {cmd:?}");
    let mounted = cmd.output();
    if let Ok(o) = &mounted
        && o.status.success()
    {
        let _mount = Mount(full.clone());
        let frames = full.join("frames");
        fs::create_dir(&frames).unwrap();
        let stderr = assert_failed_write_is_clean(
            root,
            &frames,
            || {
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
            },
            &[],
        );
        assert!(stderr.contains("No space left on device"), "{stderr}");
        println!("full file system: checked");
        return;
    }
    println!("cannot mount a tmpfs here ({mounted:?})");

    // Without mount, a read-only folder where permissions apply (not root).
    let ro = root.join("readonly");
    fs::create_dir(&ro).unwrap();
    let _unlock = Unlock(ro.clone());
    fs::set_permissions(&ro, fs::Permissions::from_mode(0o555)).unwrap();
    let enforced = fs::File::create(ro.join(".probe")).is_err();
    fs::set_permissions(&ro, fs::Permissions::from_mode(0o755)).unwrap();
    assert!(
        enforced,
        "neither a tmpfs mount nor folder permissions work here: no way to fill or lock a \
         folder (a_write_past_the_file_size_limit_fails_cleanly still checks a failing write)"
    );
    let stderr = assert_failed_write_is_clean(
        root,
        &ro,
        || fs::set_permissions(&ro, fs::Permissions::from_mode(0o555)).unwrap(),
        &[],
    );
    assert!(stderr.contains("Permission denied"), "{stderr}");
    println!("read-only folder: checked");
}

/// Starts a render of `args` in `root` with stdout and stderr to files, and returns it.
fn start(root: &Path, args: &[&str], log: &str) -> std::process::Child {
    let mut cmd = Command::new(BIN);
    cmd.args(args).current_dir(root);
    println!("$ {cmd:?} &");
    cmd.stdout(fs::File::create(root.join(format!("{log}.out"))).unwrap())
        .stderr(fs::File::create(root.join(format!("{log}.err"))).unwrap())
        .spawn()
        .expect("start raytrace")
}

/// Sends `signal` (a name for `kill -s`) to `pid`.
fn signal(pid: u32, signal: &str) {
    let ok = Command::new("kill")
        .args(["-s", signal, &pid.to_string()])
        .status()
        .is_ok_and(|s| s.success());
    assert!(ok, "kill -s {signal} {pid}");
}

/// Waits for `child` to end, at most `limit`.
fn wait_at_most(child: &mut std::process::Child, limit: Duration) -> std::process::ExitStatus {
    let start = Instant::now();
    loop {
        if let Some(status) = child.try_wait().unwrap() {
            return status;
        }
        if start.elapsed() > limit {
            let _ = child.kill();
            let _ = child.wait();
            panic!("the render did not end within {limit:?} of the signal");
        }
        std::thread::sleep(Duration::from_millis(2));
    }
}

#[test]
fn sigint_and_sigterm_leave_finished_frames_and_no_temporary_file() {
    // Small frames written every few milliseconds, signalled at varied moments after the
    // first frame, so that signals land while a frame renders and while one is written.
    const FRAMES: u32 = 5000;
    let tmp = tempfile::tempdir().unwrap();
    let root = tmp.path();
    fs::write(
        root.join("shot.toml"),
        shot(FRAMES, 1)
            .replace("width = 64", "width = 16")
            .replace("height = 36", "height = 9"),
    )
    .unwrap();
    let out = root.join("out");
    for run in 0..16u32 {
        let _ = fs::remove_dir_all(&out);
        let (name, code) = if run % 2 == 0 {
            ("INT", 130)
        } else {
            ("TERM", 143)
        };
        let mut child = start(root, &["render", "shot.toml", "--threads", "1"], "sig");
        let begun = Instant::now();
        while listing(&out).0.is_empty() {
            assert!(
                child.try_wait().unwrap().is_none(),
                "the render ended early"
            );
            assert!(
                begun.elapsed() < Duration::from_secs(60),
                "no frame within 60 s"
            );
            std::thread::sleep(Duration::from_millis(1));
        }
        std::thread::sleep(Duration::from_micros(1500 * run as u64));
        signal(child.id(), name);
        let status = wait_at_most(&mut child, Duration::from_secs(5));
        let stderr = fs::read_to_string(root.join("sig.err")).unwrap();
        assert_eq!(status.code(), Some(code), "SIG{name}: {status}\n{stderr}");
        let (frames, temps) = listing(&out);
        assert!(
            temps.is_empty(),
            "SIG{name}: temporary files left: {temps:?}"
        );
        let n = frames.len() as u32;
        assert!(n > 0 && n < FRAMES);
        assert_eq!(
            frames,
            (1..=n).collect::<Vec<_>>(),
            "frames are a prefix of the shot"
        );
        assert!(
            stderr.contains(&format!(
                "interrupted: {n} of {FRAMES} frames written (SIG{name})"
            )),
            "{stderr}"
        );
        for f in frames {
            assert_valid_exr_of(&frame_path(&out, f), 16, 9);
        }
        println!("SIG{name} after {n} frames: clean");
    }
}

#[test]
fn a_signal_during_a_long_frame_ends_the_run_at_once() {
    // Frame 1 exists; frame 2 would take minutes. SIGTERM ends the run within a second,
    // without a file for frame 2, and says what was done.
    let tmp = tempfile::tempdir().unwrap();
    let root = tmp.path();
    fs::write(root.join("shot.toml"), shot(3, 200_000)).unwrap();
    let o = run(
        root,
        &["render", "shot.toml", "--frames", "1", "--samples", "1"],
    );
    assert!(o.status.success(), "{}", text(&o));
    let out = root.join("out");
    let first = fs::read(frame_path(&out, 1)).unwrap();
    let mut child = start(root, &["render", "shot.toml", "--skip-existing"], "long");
    std::thread::sleep(Duration::from_millis(500));
    let sent = Instant::now();
    signal(child.id(), "TERM");
    let status = wait_at_most(&mut child, Duration::from_secs(5));
    let waited = sent.elapsed();
    let stderr = fs::read_to_string(root.join("long.err")).unwrap();
    assert_eq!(status.code(), Some(143), "{status}\n{stderr}");
    assert!(waited < Duration::from_secs(1), "took {waited:?} to stop");
    assert!(
        stderr.contains(
            "interrupted: 0 of 3 frames written (1 more existed and were skipped) (SIGTERM)"
        ),
        "{stderr}"
    );
    assert_eq!(listing(&out), (vec![1], vec![]));
    assert!(fs::read(frame_path(&out, 1)).unwrap() == first);

    // Into a folder that does not exist yet: nothing is created.
    let mut child = start(
        root,
        &[
            "render",
            "shot.toml",
            "--output",
            "new/deeper/shot_####.exr",
        ],
        "fresh",
    );
    std::thread::sleep(Duration::from_millis(300));
    signal(child.id(), "INT");
    let status = wait_at_most(&mut child, Duration::from_secs(5));
    let stderr = fs::read_to_string(root.join("fresh.err")).unwrap();
    assert_eq!(status.code(), Some(130), "{status}\n{stderr}");
    assert!(
        stderr.contains("interrupted: 0 of 3 frames written (SIGINT)"),
        "{stderr}"
    );
    assert!(!root.join("new").exists(), "a folder was left");
}
