//! A shot rendered as a Slurm job array on a real one-node cluster (munged, slurmctld and
//! slurmd on loopback, private to this test) gives exactly the frames of a single-process
//! render, bit for bit, and resubmitting the array fills in missing frames only; a batch of
//! two shots renders as one array, and a job that depends on it (afterok) makes their clips.
//!
//! Needs the Debian packages `munge slurmctld slurmd slurm-client`. Without them the test is
//! skipped with a message, except under `CI=true`, where it fails.

use std::fs;
use std::io::Read;
use std::net::TcpListener;
use std::os::unix::fs::PermissionsExt;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::time::{Duration, Instant};

const BIN: &str = env!("CARGO_BIN_EXE_raytrace");
const CHUNK_SIZE: usize = 5;
const FRAMES: usize = 12;

const SHOT: &str = r#"
[shot]
fps = 24.0
frames = 12
first_frame = 1
shutter_angle = 180.0

[output]
path = "renders/shot_####.exr"
width = 64
height = 36

[render]
samples = 8
max_depth = 8
seed = 7

[camera]
look_from = [0.0, 1.5, 6.0]
look_at = [0.0, 0.5, 0.0]
vfov = 35.0
aperture = 0.05

[materials]
ground = { type = "lambertian", albedo = [0.5, 0.5, 0.5] }
red = { type = "lambertian", albedo = [0.7, 0.2, 0.1] }
steel = { type = "metal", albedo = [0.8, 0.8, 0.9], fuzz = 0.1 }
glass = { type = "dielectric", ior = 1.5 }

[[sphere]]
center = [0.0, -1000.0, 0.0]
radius = 1000.0
material = "ground"

[[sphere]]
center = [-1.2, 0.5, 0.0]
radius = 0.5
material = "steel"

[[sphere]]
center = [1.2, 0.5, 0.0]
radius = 0.5
material = "glass"

[[sphere]]
center = [-1.0, 0.4, 1.0]
radius = 0.4
material = "red"
velocity = [2.0, 0.0, 0.0]
"#;

/// `name` on PATH or in the usual sbin folders (daemons live there and root's PATH may lack them).
fn find_tool(name: &str) -> Option<PathBuf> {
    let path = std::env::var_os("PATH").unwrap_or_default();
    std::env::split_paths(&path)
        .chain(["/usr/sbin", "/sbin", "/usr/local/sbin"].map(PathBuf::from))
        .map(|dir| dir.join(name))
        .find(|p| fs::metadata(p).is_ok_and(|m| m.is_file() && m.permissions().mode() & 0o111 != 0))
}

struct Tools {
    munged: PathBuf,
    slurmctld: PathBuf,
    slurmd: PathBuf,
    sbatch: PathBuf,
    sinfo: PathBuf,
    scancel: PathBuf,
}

/// The Slurm and munge programs, or the names of the missing ones.
fn tools() -> Result<Tools, Vec<&'static str>> {
    let names = [
        "munged",
        "slurmctld",
        "slurmd",
        "sbatch",
        "sinfo",
        "scancel",
    ];
    let found: Vec<Option<PathBuf>> = names.iter().map(|n| find_tool(n)).collect();
    let missing: Vec<&str> = names
        .iter()
        .zip(&found)
        .filter(|(_, f)| f.is_none())
        .map(|(n, _)| *n)
        .collect();
    if !missing.is_empty() {
        return Err(missing);
    }
    let mut found = found.into_iter().map(Option::unwrap);
    let mut next = || found.next().unwrap();
    Ok(Tools {
        munged: next(),
        slurmctld: next(),
        slurmd: next(),
        sbatch: next(),
        sinfo: next(),
        scancel: next(),
    })
}

/// The last `n` lines of a file, for failure messages.
fn tail(path: &Path, n: usize) -> String {
    let text = fs::read_to_string(path).unwrap_or_else(|e| format!("({}: {e})", path.display()));
    let lines: Vec<&str> = text.lines().collect();
    let start = lines.len().saturating_sub(n);
    format!("--- {} ---\n{}", path.display(), lines[start..].join("\n"))
}

/// Waits for `child` at most `limit`; `None` if it is still running then.
fn wait_bounded(child: &mut Child, limit: Duration) -> Option<ExitStatus> {
    let start = Instant::now();
    loop {
        match child.try_wait() {
            Ok(Some(status)) => return Some(status),
            Ok(None) if start.elapsed() < limit => std::thread::sleep(Duration::from_millis(50)),
            Ok(None) => return None,
            Err(e) => panic!("waiting for a child process: {e}"),
        }
    }
}

/// What a finished command printed.
struct Run {
    status: ExitStatus,
    stdout: String,
    stderr: String,
}

/// Prints and runs `cmd` with its output captured in files under `logs`, killing it (and
/// failing) if it runs longer than `limit`.
fn run(cmd: &mut Command, logs: &Path, name: &str, limit: Duration) -> Run {
    println!("$ {cmd:?}");
    let out_path = logs.join(format!("{name}.stdout"));
    let err_path = logs.join(format!("{name}.stderr"));
    let mut child = cmd
        .stdin(Stdio::null())
        .stdout(fs::File::create(&out_path).unwrap())
        .stderr(fs::File::create(&err_path).unwrap())
        .spawn()
        .unwrap_or_else(|e| panic!("cannot run {cmd:?}: {e}"));
    let status = wait_bounded(&mut child, limit).unwrap_or_else(|| {
        let _ = child.kill();
        let _ = child.wait();
        panic!(
            "{name} did not finish within {limit:?}\n{}\n{}",
            tail(&out_path, 40),
            tail(&err_path, 40)
        )
    });
    let read = |p: &Path| fs::read_to_string(p).unwrap_or_default();
    let run = Run {
        status,
        stdout: read(&out_path),
        stderr: read(&err_path),
    };
    for line in run.stdout.lines().chain(run.stderr.lines()) {
        println!("  {line}");
    }
    run
}

/// A daemon started in the foreground, with its output in `log`.
struct Daemon {
    name: &'static str,
    child: Child,
    log: PathBuf,
}

impl Daemon {
    fn start(name: &'static str, cmd: &mut Command, log: PathBuf) -> Daemon {
        println!("$ {cmd:?} &");
        let child = cmd
            .stdin(Stdio::null())
            .stdout(fs::File::create(&log).unwrap())
            .stderr(fs::File::create(log.with_extension("stderr")).unwrap())
            .spawn()
            .unwrap_or_else(|e| panic!("cannot start {name}: {e}"));
        Daemon { name, child, log }
    }

    /// SIGTERM, then SIGKILL if it has not exited after a few seconds; always reaped.
    fn stop(&mut self) {
        if let Ok(Some(_)) = self.child.try_wait() {
            return;
        }
        let pid = self.child.id().to_string();
        let termed = Command::new("kill")
            .args(["-TERM", &pid])
            .stderr(Stdio::null())
            .status()
            .is_ok_and(|s| s.success());
        if !termed || wait_bounded(&mut self.child, Duration::from_secs(10)).is_none() {
            println!("{} (pid {pid}) did not stop on SIGTERM: SIGKILL", self.name);
            let _ = self.child.kill();
            let _ = self.child.wait();
        } else {
            println!("stopped {} (pid {pid})", self.name);
        }
    }

    /// Fails with the daemon's log if it has exited.
    fn assert_running(&mut self) {
        if let Ok(Some(status)) = self.child.try_wait() {
            panic!(
                "{} exited early ({status})\n{}\n{}",
                self.name,
                tail(&self.log, 40),
                tail(&self.log.with_extension("stderr"), 40)
            );
        }
    }
}

/// The test's private cluster. Dropping it (also when the test panics) cancels any jobs
/// left and stops the daemons by pid in reverse start order: slurmd, slurmctld, munged.
struct Cluster {
    daemons: Vec<Daemon>,
    scancel: PathBuf,
    conf: PathBuf,
    user: String,
}

impl Drop for Cluster {
    fn drop(&mut self) {
        if std::thread::panicking() && self.daemons.iter().any(|d| d.name == "slurmctld") {
            // Jobs still queued or running after a failure: cancel them so no job step
            // outlives the cluster.
            if let Ok(mut c) = Command::new(&self.scancel)
                .args(["--user", &self.user])
                .env("SLURM_CONF", &self.conf)
                .stdout(Stdio::null())
                .stderr(Stdio::null())
                .spawn()
                && wait_bounded(&mut c, Duration::from_secs(10)).is_none()
            {
                let _ = c.kill();
                let _ = c.wait();
            }
        }
        while let Some(mut daemon) = self.daemons.pop() {
            daemon.stop();
        }
    }
}

impl Cluster {
    fn assert_running(&mut self) {
        for d in &mut self.daemons {
            d.assert_running();
        }
    }

    fn logs(&self) -> String {
        self.daemons
            .iter()
            .map(|d| {
                format!(
                    "{}\n{}",
                    tail(&d.log, 30),
                    tail(&d.log.with_extension("stderr"), 30)
                )
            })
            .collect::<Vec<_>>()
            .join("\n")
    }
}

/// Two TCP ports that are free on loopback right now.
fn free_ports() -> (u16, u16) {
    let a = TcpListener::bind("127.0.0.1:0").unwrap();
    let b = TcpListener::bind("127.0.0.1:0").unwrap();
    (
        a.local_addr().unwrap().port(),
        b.local_addr().unwrap().port(),
    )
}

fn user_name() -> String {
    let out = Command::new("id").arg("-un").output().expect("run id -un");
    String::from_utf8_lossy(&out.stdout).trim().to_string()
}

/// The names and contents of the files in `dir`, sorted by name.
fn dir_files(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut files: Vec<(String, Vec<u8>)> = fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| {
            let e = e.unwrap();
            (
                e.file_name().to_string_lossy().into_owned(),
                fs::read(e.path()).unwrap(),
            )
        })
        .collect();
    files.sort();
    files
}

fn expected_names() -> Vec<String> {
    (1..=FRAMES).map(|f| format!("shot_{f:04}.exr")).collect()
}

/// Checks that `farm` holds exactly the 12 frames of `single`, byte for byte.
fn assert_same_frames(farm: &Path, single: &Path) {
    let farm_files = dir_files(farm);
    let single_files = dir_files(single);
    let names =
        |files: &[(String, Vec<u8>)]| files.iter().map(|(n, _)| n.clone()).collect::<Vec<_>>();
    assert_eq!(
        names(&farm_files),
        expected_names(),
        "files in {}",
        farm.display()
    );
    assert_eq!(
        names(&single_files),
        expected_names(),
        "files in {}",
        single.display()
    );
    for ((name, a), (_, b)) in farm_files.iter().zip(&single_files) {
        assert!(
            a == b,
            "{name}: the farm's frame differs from the single-process render"
        );
    }
}

#[test]
fn job_array_renders_the_same_frames_as_one_process() {
    let tools = match tools() {
        Ok(tools) => tools,
        Err(missing) => {
            let msg = format!(
                "Slurm not installed (missing {}; apt-get install munge slurmctld slurmd slurm-client)",
                missing.join(", ")
            );
            if std::env::var("CI").as_deref() == Ok("true") {
                panic!("CI=true but {msg}");
            }
            println!(
                "skipped: Slurm not installed (apt-get install munge slurmctld slurmd slurm-client)"
            );
            eprintln!("skipped: {msg}");
            return;
        }
    };
    let started = Instant::now();
    let tmp = tempfile::tempdir().unwrap();
    let root = tmp.path();
    let (logs, munge, state, spool) = (
        root.join("logs"),
        root.join("munge"),
        root.join("state"),
        root.join("spool"),
    );
    for d in [&logs, &munge, &state, &spool] {
        fs::create_dir_all(d).unwrap();
    }

    // munge: a fresh key, readable only by the user munged runs as.
    let key = munge.join("munge.key");
    let mut bytes = vec![0u8; 1024];
    fs::File::open("/dev/urandom")
        .and_then(|mut f| f.read_exact(&mut bytes))
        .expect("read /dev/urandom");
    fs::write(&key, &bytes).unwrap();
    fs::set_permissions(&key, fs::Permissions::from_mode(0o400)).unwrap();
    let socket = munge.join("munge.socket");

    // slurm.conf: one node (this machine, on loopback), private ports and folders.
    let user = user_name();
    let cpus = std::thread::available_parallelism().map_or(1, |n| n.get());
    let (ctld_port, slurmd_port) = free_ports();
    let conf = root.join("slurm.conf");
    let r = |p: &Path| p.display().to_string();
    let conf_text = format!(
        "ClusterName=raytracetest
SlurmctldHost=localhost
SlurmctldPort={ctld_port}
SlurmdPort={slurmd_port}
SlurmUser={user}
SlurmdUser={user}
AuthType=auth/munge
AuthInfo=socket={socket}
CredType=cred/munge
StateSaveLocation={state}
SlurmdSpoolDir={spool}
SlurmctldPidFile={root}/slurmctld.pid
SlurmdPidFile={root}/slurmd.pid
SlurmctldLogFile={logs}/slurmctld.log
SlurmdLogFile={logs}/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
AccountingStorageType=accounting_storage/none
JobAcctGatherType=jobacct_gather/none
JobCompType=jobcomp/none
SchedulerType=sched/builtin
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
MpiDefault=none
MailProg=/bin/true
ReturnToService=2
NodeName=localhost NodeAddr=127.0.0.1 CPUs={cpus} State=UNKNOWN
PartitionName=debug Nodes=localhost Default=YES MaxTime=INFINITE State=UP
",
        socket = r(&socket),
        state = r(&state),
        spool = r(&spool),
        root = r(root),
        logs = r(&logs),
    );
    fs::write(&conf, &conf_text).unwrap();
    println!("slurm.conf:\n{conf_text}");

    let mut cluster = Cluster {
        daemons: Vec::new(),
        scancel: tools.scancel.clone(),
        conf: conf.clone(),
        user: user.clone(),
    };
    cluster.daemons.push(Daemon::start(
        "munged",
        Command::new(&tools.munged)
            .arg("--foreground")
            .arg("--force")
            .arg(format!("--socket={}", socket.display()))
            .arg(format!("--key-file={}", key.display()))
            .arg(format!("--pid-file={}", munge.join("munged.pid").display()))
            .arg(format!("--log-file={}", munge.join("munged.log").display()))
            .arg(format!(
                "--seed-file={}",
                munge.join("munged.seed").display()
            )),
        logs.join("munged.out"),
    ));
    let deadline = Instant::now() + Duration::from_secs(15);
    while !socket.exists() {
        cluster.assert_running();
        assert!(
            Instant::now() < deadline,
            "munged made no socket in 15 s\n{}",
            cluster.logs()
        );
        std::thread::sleep(Duration::from_millis(50));
    }
    cluster.daemons.push(Daemon::start(
        "slurmctld",
        Command::new(&tools.slurmctld)
            .arg("-D")
            .arg("-i")
            .env("SLURM_CONF", &conf),
        logs.join("slurmctld.out"),
    ));
    cluster.daemons.push(Daemon::start(
        "slurmd",
        Command::new(&tools.slurmd)
            .args(["-D", "-N", "localhost"])
            .env("SLURM_CONF", &conf),
        logs.join("slurmd.out"),
    ));

    // Wait (bounded) for the node to come up idle.
    let deadline = Instant::now() + Duration::from_secs(60);
    loop {
        cluster.assert_running();
        let out = Command::new(&tools.sinfo)
            .args(["-h", "-N", "-n", "localhost", "-o", "%T"])
            .env("SLURM_CONF", &conf)
            .stderr(Stdio::null())
            .output()
            .expect("run sinfo");
        let state = String::from_utf8_lossy(&out.stdout).trim().to_string();
        if state == "idle" {
            println!(
                "node localhost idle after {:.1} s",
                started.elapsed().as_secs_f64()
            );
            break;
        }
        assert!(
            Instant::now() < deadline,
            "node not idle within 60 s (sinfo says {state:?})\n{}",
            cluster.logs()
        );
        std::thread::sleep(Duration::from_millis(250));
    }

    // The shot, and its chunk count as the farm docs compute it.
    let scene = root.join("shot.toml");
    fs::write(&scene, SHOT).unwrap();
    let check = run(
        Command::new(BIN)
            .args([
                "check",
                "shot.toml",
                "--chunk-size",
                &CHUNK_SIZE.to_string(),
            ])
            .current_dir(root),
        &logs,
        "check",
        Duration::from_secs(30),
    );
    assert!(
        check.status.success(),
        "raytrace check failed: {}",
        check.stderr
    );
    let chunks: usize = check
        .stdout
        .lines()
        .find_map(|l| l.strip_prefix("chunks:"))
        .and_then(|rest| rest.split_whitespace().next())
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("no `chunks: N` line in:\n{}", check.stdout));
    assert_eq!(chunks, FRAMES.div_ceil(CHUNK_SIZE));

    let contrib = Path::new(env!("CARGO_MANIFEST_DIR")).join("contrib/slurm");
    let script = contrib.join("render-shot.sbatch");
    let farm = root.join("farm");
    let pattern = farm.join("shot_####.exr");
    let submit = |name: &str| {
        let r = run(
            Command::new(&tools.sbatch)
                .arg("--wait")
                .arg(format!("--array=0-{}", chunks - 1))
                .arg("--time=10")
                .arg(&script)
                .arg("shot.toml")
                .arg(CHUNK_SIZE.to_string())
                .arg("--output")
                .arg(&pattern)
                .env("SLURM_CONF", &conf)
                .env("RAYTRACE", BIN)
                .current_dir(root),
            &logs,
            name,
            Duration::from_secs(90),
        );
        // The array's task logs (render-shot-<job>_<task>.out): empty unless a task failed.
        let mut task_logs: Vec<PathBuf> = fs::read_dir(root)
            .unwrap()
            .map(|e| e.unwrap().path())
            .filter(|p| p.extension().is_some_and(|e| e == "out"))
            .collect();
        task_logs.sort();
        let task_logs: Vec<String> = task_logs.iter().map(|p| tail(p, 20)).collect();
        assert!(
            r.status.success(),
            "sbatch --wait failed ({})\n{}\n{}\n{}",
            r.status,
            r.stderr,
            task_logs.join("\n"),
            cluster.logs()
        );
    };
    let t = Instant::now();
    submit("sbatch");
    println!("job array finished in {:.1} s", t.elapsed().as_secs_f64());

    // The same shot in one process, all cores.
    let single = root.join("single");
    let one = run(
        Command::new(BIN)
            .args(["render", "shot.toml", "--output"])
            .arg(single.join("shot_####.exr"))
            .current_dir(root),
        &logs,
        "single",
        Duration::from_secs(120),
    );
    assert!(
        one.status.success(),
        "single-process render failed: {}",
        one.stderr
    );
    assert_same_frames(&farm, &single);

    // Resume: with two frames gone, resubmitting the same array renders just those two.
    let untouched: Vec<(PathBuf, std::time::SystemTime)> = expected_names()
        .iter()
        .map(|n| farm.join(n))
        .filter(|p| !p.ends_with("shot_0003.exr") && !p.ends_with("shot_0011.exr"))
        .map(|p| {
            let m = fs::metadata(&p).unwrap().modified().unwrap();
            (p, m)
        })
        .collect();
    fs::remove_file(farm.join("shot_0003.exr")).unwrap();
    fs::remove_file(farm.join("shot_0011.exr")).unwrap();
    let t = Instant::now();
    submit("sbatch-resume");
    println!(
        "resubmitted array finished in {:.1} s",
        t.elapsed().as_secs_f64()
    );
    assert_same_frames(&farm, &single);
    for (p, m) in untouched {
        assert_eq!(
            fs::metadata(&p).unwrap().modified().unwrap(),
            m,
            "{} was rewritten on resume",
            p.display()
        );
    }

    // A batch: this shot and a 3-frame one as one array (15 frames, 3 chunks), then a clip
    // of each shot in a job that waits for the whole array (afterok), as docs/farm.md shows.
    fs::write(
        root.join("short.toml"),
        SHOT.replace("frames = 12", "frames = 3"),
    )
    .unwrap();
    let dir = |name: &str| contrib.join(name);
    let batch = root.join("batch");
    let array = run(
        Command::new(&tools.sbatch)
            .args(["--parsable", "--array=0-2", "--time=10"])
            .arg(dir("render-batch.sbatch"))
            .args(["5", "shot.toml", "short.toml", "--", "--output"])
            .arg(batch.join("{scene}_####.exr"))
            .env("SLURM_CONF", &conf)
            .env("RAYTRACE", BIN)
            .current_dir(root),
        &logs,
        "sbatch-batch",
        Duration::from_secs(30),
    );
    assert!(array.status.success(), "{}", array.stderr);
    let job = array.stdout.trim().split(';').next().unwrap().to_string();
    let clips = run(
        Command::new(&tools.sbatch)
            .args(["--wait", "--time=10"])
            .arg(format!("--dependency=afterok:{job}"))
            .arg(dir("clip-shots.sbatch"))
            .arg(root.join("clips/{scene}.apng"))
            .args(["shot.toml", "short.toml", "--", "--input"])
            .arg(batch.join("{scene}_####.exr"))
            .env("SLURM_CONF", &conf)
            .env("RAYTRACE", BIN)
            .current_dir(root),
        &logs,
        "sbatch-clips",
        Duration::from_secs(120),
    );
    assert!(
        clips.status.success(),
        "the clip job failed ({})\n{}\n{}",
        clips.status,
        clips.stderr,
        cluster.logs()
    );
    // Every frame of the batch, the long shot's as the single-process render's.
    let batch_files = dir_files(&batch);
    let mut want: Vec<String> = expected_names();
    want.extend((1..=3).map(|f| format!("short_{f:04}.exr")));
    want.sort();
    assert_eq!(
        batch_files
            .iter()
            .map(|(n, _)| n.clone())
            .collect::<Vec<_>>(),
        want
    );
    let long = batch_files.iter().filter(|(n, _)| n.starts_with("shot_"));
    for ((name, a), (_, b)) in long.zip(dir_files(&single)) {
        assert!(*a == b, "{name}: the batch's frame differs");
    }
    // Each clip: an APNG of its shot's frame count.
    for (clip, frames) in [("shot.apng", FRAMES), ("short.apng", 3)] {
        let file = fs::File::open(root.join("clips").join(clip)).unwrap();
        let reader = png::Decoder::new(std::io::BufReader::new(file))
            .read_info()
            .unwrap();
        let actl = reader.info().animation_control.expect("an animated PNG");
        assert_eq!(actl.num_frames as usize, frames, "{clip}");
    }

    drop(cluster);
    println!("slurm test took {:.1} s", started.elapsed().as_secs_f64());
}
