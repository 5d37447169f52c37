//! The documentation's commands, run: every fenced `sh` block of README.md and docs/*.md
//! (read as `common::doc_blocks` says), with `raytrace` the binary just built, in a
//! temporary copy of the files the docs use, shrunk by `RAYTRACE_DOCS_SMALL=1` (frames of
//! 32x18 pixels and a few samples: `src/cli/small.rs`). Each block must exit as its page says
//! (every `raytrace` in it with the status its `exit=` gives, 0 by default) and the output it
//! quotes must match the output's shape (`common::shape`). A page's blocks run in order in
//! one directory, so a block may use what an earlier one wrote.
//!
//! The directory holds the repository's `scenes/*.toml`, `examples/`, `contrib/`, `bench/`
//! and `docs/data/`, an empty `docs/images/`, and `shot.toml`, `a.toml` and `b.toml`, the
//! shots the docs' examples name: copies of `scenes/quick.toml` (12 frames). A block runs
//! with `SLURM_ARRAY_TASK_ID` and `JOB_COMPLETION_INDEX` set to 0, as its first task would.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

use crate::common::doc_blocks::{Block, sh_blocks};
use crate::common::shape::first_unmatched;

/// The pages whose commands are run: every one (`every_page_is_run` keeps this whole).
const PAGES: &[&str] = &[
    "README.md",
    "docs/architecture.md",
    "docs/convergence.md",
    "docs/denoising.md",
    "docs/farm.md",
    "docs/gpu.md",
    "docs/performance.md",
    "docs/preview.md",
    "docs/robustness.md",
    "docs/scene-format.md",
    "docs/simulations.md",
    "docs/stability.md",
];

/// The repository's folders a page's commands may read, copied whole.
const COPIED: &[&str] = &["examples", "contrib", "bench", "docs/data"];

/// The longest a block may run, in seconds (`timeout`), so a command that waits forever
/// fails instead of hanging the suite.
const BLOCK_SECONDS: u32 = 120;

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

fn copy_tree(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for entry in std::fs::read_dir(from).unwrap() {
        let entry = entry.unwrap();
        let target = to.join(entry.file_name());
        if entry.file_type().unwrap().is_dir() {
            copy_tree(&entry.path(), &target);
        } else {
            std::fs::copy(entry.path(), &target).unwrap();
        }
    }
}

/// A fresh directory as the module's doc describes, with `bin/raytrace` (outside it): the
/// binary, through a script that logs each run's exit status to `statuses`.
fn workspace() -> (tempfile::TempDir, PathBuf) {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("repo");
    for folder in COPIED {
        copy_tree(&root().join(folder), &dir.join(folder));
    }
    std::fs::create_dir_all(dir.join("scenes")).unwrap();
    std::fs::create_dir_all(dir.join("docs/images")).unwrap();
    for entry in std::fs::read_dir(root().join("scenes")).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "toml") {
            std::fs::copy(&path, dir.join("scenes").join(path.file_name().unwrap())).unwrap();
        }
    }
    for shot in ["shot.toml", "a.toml", "b.toml"] {
        std::fs::copy(root().join("scenes/quick.toml"), dir.join(shot)).unwrap();
    }
    let bin = tmp.path().join("bin");
    std::fs::create_dir_all(&bin).unwrap();
    // `trap :` keeps the shim alive to log the status when a `serves=` block is interrupted
    // (a handler, unlike an ignored signal, is not inherited by the binary).
    let shim = format!(
        "#!/bin/sh\ntrap : INT TERM\n\"{}\" \"$@\"\ns=$?\necho $s >> \"{}\"\nexit $s\n",
        env!("CARGO_BIN_EXE_raytrace"),
        tmp.path().join("statuses").display()
    );
    let raytrace = bin.join("raytrace");
    std::fs::write(&raytrace, shim).unwrap();
    use std::os::unix::fs::PermissionsExt;
    std::fs::set_permissions(&raytrace, std::fs::Permissions::from_mode(0o755)).unwrap();
    (tmp, dir)
}

/// Whether `need` is here: a GPU adapter, or a program on the PATH. Under CI=true a missing
/// one fails (`.ci/run` installs them all).
fn have(need: &str) -> bool {
    let present = match need {
        "gpu" => crate::common::gpu().is_some(),
        "slurm" => on_path("sbatch"),
        "time" => Path::new("/usr/bin/time").exists(),
        "ffmpeg" | "lmp" | "hyperfine" | "oiiotool" => on_path(need),
        _ => panic!("`needs={need}`: not a thing this test knows how to find"),
    };
    assert!(
        present || std::env::var("CI").as_deref() != Ok("true"),
        "CI=true and `{need}` is missing"
    );
    present
}

fn on_path(program: &str) -> bool {
    Command::new("sh")
        .args(["-c", &format!("command -v {program}")])
        .stdout(Stdio::null())
        .status()
        .is_ok_and(|s| s.success())
}

/// Runs one block in `dir`; what went wrong, if anything.
fn run_block(block: &Block, dir: &Path, page: &str) -> Result<(), String> {
    let tmp = dir.parent().unwrap();
    let statuses = tmp.join("statuses");
    let _ = std::fs::remove_file(&statuses);
    let out_path = tmp.join("output");
    let out = std::fs::File::create(&out_path).unwrap();
    let strict = if block.exit == 0 { "set -e; " } else { "" };
    let path = format!(
        "{}:{}",
        tmp.join("bin").display(),
        std::env::var("PATH").unwrap()
    );
    let mut timeout = Command::new("timeout");
    match block.serves {
        Some(seconds) => timeout.args(["-s", "INT", &seconds.to_string()]),
        None => timeout.arg(BLOCK_SECONDS.to_string()),
    };
    let status = timeout
        .args(["bash", "-o", "pipefail", "-c"])
        .arg(format!("{strict}{}", block.script))
        .current_dir(dir)
        .env("PATH", path)
        .env("RAYTRACE_DOCS_SMALL", "1")
        .env("SLURM_ARRAY_TASK_ID", "0")
        .env("JOB_COMPLETION_INDEX", "0")
        .stdin(Stdio::null())
        .stdout(out.try_clone().unwrap())
        .stderr(out)
        .status()
        .unwrap();
    let output = std::fs::read_to_string(&out_path).unwrap_or_default();
    let exits: Vec<i32> = std::fs::read_to_string(&statuses)
        .unwrap_or_default()
        .lines()
        .map(|l| l.parse().unwrap())
        .collect();
    let at = format!("{page}:{}", block.line);
    if block.serves.is_some() && status.code() != Some(124) {
        return Err(format!(
            "{at}: the block should serve until stopped, but it ended ({status}):\n{output}"
        ));
    }
    if block.exit == 0 && !status.success() {
        return Err(format!("{at}: the block failed ({status}):\n{output}"));
    }
    if block.exit != 0 && exits.is_empty() {
        return Err(format!(
            "{at}: exit={} but no raytrace ran:\n{output}",
            block.exit
        ));
    }
    if let Some(bad) = exits.iter().find(|&&e| e != block.exit) {
        return Err(format!(
            "{at}: a raytrace exited {bad}, the page says {}:\n{output}",
            block.exit
        ));
    }
    if let Some(line) = block
        .quoted
        .as_deref()
        .and_then(|q| first_unmatched(q, &output))
    {
        return Err(format!(
            "{at}: the quoted line\n  {line}\nis not in the output:\n{output}"
        ));
    }
    Ok(())
}

/// Runs every block of `page` that can run here; panics naming each one that failed.
fn run_page(page: &str) {
    let text = std::fs::read_to_string(root().join(page)).unwrap();
    let (_tmp, dir) = workspace();
    let mut failures = Vec::new();
    for block in sh_blocks(&text) {
        if let Some(reason) = &block.skip {
            println!("{page}:{}: not run: {reason}", block.line);
            continue;
        }
        if let Some(missing) = block.needs.iter().find(|n| !have(n)) {
            println!("{page}:{}: skipped: no {missing} here", block.line);
            continue;
        }
        let start = std::time::Instant::now();
        if let Err(e) = run_block(&block, &dir, page) {
            failures.push(e);
        }
        println!(
            "{page}:{}: {:.1} s",
            block.line,
            start.elapsed().as_secs_f64()
        );
    }
    assert!(failures.is_empty(), "{}", failures.join("\n\n"));
}

#[test]
fn every_page_is_run() {
    let mut pages = vec!["README.md".to_string()];
    for entry in std::fs::read_dir(root().join("docs")).unwrap() {
        let name = entry.unwrap().file_name().into_string().unwrap();
        if name.ends_with(".md") {
            pages.push(format!("docs/{name}"));
        }
    }
    pages.sort();
    let mut listed: Vec<String> = PAGES.iter().map(|p| p.to_string()).collect();
    listed.sort();
    assert_eq!(pages, listed, "docs.rs's PAGES must list every page");
}

/// A test per page, so that the pages run side by side.
macro_rules! page_tests {
    ($($name:ident => $page:literal),* $(,)?) => {
        $(#[test]
        fn $name() {
            assert!(PAGES.contains(&$page));
            run_page($page);
        })*
    };
}

page_tests! {
    readme => "README.md",
    architecture => "docs/architecture.md",
    convergence => "docs/convergence.md",
    denoising => "docs/denoising.md",
    farm => "docs/farm.md",
    gpu => "docs/gpu.md",
    performance => "docs/performance.md",
    preview => "docs/preview.md",
    robustness => "docs/robustness.md",
    scene_format => "docs/scene-format.md",
    simulations => "docs/simulations.md",
    stability => "docs/stability.md",
}
