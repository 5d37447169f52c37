//! The processor a build needs (`src/cpu.rs`): run under QEMU's user-mode emulation as a
//! processor of 2008 (Nehalem: SSE4.2, no AVX) and one of 2013 (Haswell: x86-64-v3). An
//! x86-64-v3 build (`.cargo/config.toml`) stops on the first with exit 1 and a message that
//! says how to build for it, before any instruction it lacks (not an illegal instruction);
//! a build for any x86-64 runs on both.

use std::process::Command;

/// `raytrace --version` on the emulated processor `cpu`: its exit status and its output.
fn version_on(cpu: &str) -> (Option<i32>, String) {
    let out = Command::new("qemu-x86_64")
        .args(["-cpu", cpu, env!("CARGO_BIN_EXE_raytrace"), "--version"])
        .output()
        .expect("qemu-x86_64 runs");
    // QEMU warns of host features its emulation leaves out; the binary's own lines remain.
    let text = String::from_utf8_lossy(&out.stdout).into_owned()
        + &String::from_utf8_lossy(&out.stderr)
            .lines()
            .filter(|l| !l.starts_with("qemu-x86_64: warning"))
            .map(|l| format!("{l}\n"))
            .collect::<String>();
    (out.status.code(), text)
}

/// Whether `qemu-x86_64` runs; without it the test is skipped with a note, except under
/// CI=true (where .ci/run installs it), where it fails.
fn have_qemu() -> bool {
    if Command::new("qemu-x86_64")
        .arg("-version")
        .output()
        .is_ok_and(|o| o.status.success())
    {
        return true;
    }
    let msg =
        "qemu-x86_64 is needed to emulate older processors (Debian: apt-get install qemu-user)";
    if std::env::var("CI").as_deref() == Ok("true") {
        panic!("CI=true but {msg}");
    }
    eprintln!("skipped: {msg}");
    false
}

#[cfg(target_arch = "x86_64")]
#[test]
fn an_older_processor_is_told_how_to_build_and_a_newer_one_runs() {
    if !have_qemu() {
        return;
    }
    let (code, text) = version_on("Haswell");
    assert_eq!(code, Some(0), "{text}");
    assert!(text.starts_with("raytrace "), "{text}");
    let (code, text) = version_on("Nehalem");
    if cfg!(target_feature = "avx2") {
        assert_eq!(code, Some(1), "{text}");
        // Nehalem has SSE4.2 and POPCNT, none of AVX, AVX2, FMA and the rest.
        assert!(
            text.starts_with("error: this raytrace was built for x86-64-v3 processors")
                && text.contains("this one lacks fma movbe avx f16c bmi1 avx2 bmi2 lzcnt;")
                && text.contains("`RUSTFLAGS= cargo install --path .`"),
            "{text}"
        );
    } else {
        // A build for any x86-64 (RUSTFLAGS= ...) needs nothing of it.
        assert_eq!(code, Some(0), "{text}");
    }
}
