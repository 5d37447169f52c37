//! The house's rules that the compiler does not check (docs/architecture.md states them). The
//! workspace's crates hold the layers, and the compiler refuses a circle between them; these
//! tests hold what is left:
//! - each library crate depends only on the crates below it ([`LAYERS`]), and none of them on
//!   the command line's, the preview's or the plots' libraries ([`BINARY_ONLY`]);
//! - every `pub` item of a library crate is named outside it, or in the signature of
//!   another `pub` item of its crate (its interface); else it is the crate's own, and the
//!   dead-code lint sees it (the `unreachable_pub` lint, on for every crate, keeps an item
//!   that no other crate can reach from being `pub`);
//! - no source file holds more than [`MAX_LINES`] lines outside its tests;
//! - no command module imports another.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

/// The library crates, lowest first, with the workspace crates each may depend on.
const LAYERS: [(&str, &[&str]); 6] = [
    ("core", &[]),
    ("io", &["raytrace-core"]),
    ("scene", &["raytrace-core", "raytrace-io"]),
    ("denoise", &["raytrace-core"]),
    ("gpu", &["raytrace-core"]),
    (
        "render",
        &[
            "raytrace-core",
            "raytrace-io",
            "raytrace-scene",
            "raytrace-denoise",
            "raytrace-gpu",
        ],
    ),
];

/// Libraries only the binary uses: the command line, its progress bars, the preview's server
/// and page, converge's plots and perceptual metric.
const BINARY_ONLY: [&str; 11] = [
    "clap",
    "indicatif",
    "hyper",
    "hyper-util",
    "tokio",
    "notify",
    "serde_json",
    "base64",
    "plotters",
    "nv-flip",
    "signal-hook",
];

/// Largest number of lines outside tests a source file may hold.
const MAX_LINES: usize = 700;

/// The command modules of the binary, which must not import one another.
const COMMANDS: [&str; 7] = [
    "render", "check", "clip", "converge", "flicker", "generate", "preview",
];

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The `.rs` files under `dir`, recursively, sorted.
fn rust_files(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let Ok(entries) = std::fs::read_dir(dir) else {
        return out;
    };
    for entry in entries.flatten() {
        let path = entry.path();
        if path.is_dir() {
            out.extend(rust_files(&path));
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
    out.sort();
    out
}

/// The names of a manifest's `[dependencies]` (not its dev- or build-dependencies: tests and
/// build scripts may use what the library does not).
fn dependencies(manifest: &Path) -> BTreeSet<String> {
    let text = std::fs::read_to_string(manifest).unwrap();
    let value: toml::Table = text.parse().unwrap();
    let mut names: BTreeSet<String> = value
        .get("dependencies")
        .and_then(|d| d.as_table())
        .map(|t| t.keys().cloned().collect())
        .unwrap_or_default();
    // Target-specific dependencies count too.
    if let Some(targets) = value.get("target").and_then(|t| t.as_table()) {
        for target in targets.values() {
            if let Some(d) = target.get("dependencies").and_then(|d| d.as_table()) {
                names.extend(d.keys().cloned());
            }
        }
    }
    names
}

#[test]
fn each_library_crate_depends_only_on_the_layers_below_it() {
    for (name, allowed) in LAYERS {
        let deps = dependencies(&root().join("crates").join(name).join("Cargo.toml"));
        for dep in &deps {
            if dep.starts_with("raytrace") {
                assert!(
                    allowed.contains(&dep.as_str()),
                    "raytrace-{name} depends on {dep}, which is not below it ({allowed:?})"
                );
            }
            assert!(
                !BINARY_ONLY.contains(&dep.as_str()),
                "raytrace-{name} depends on {dep}, which only the binary may use"
            );
        }
    }
    // Every crate of the workspace is in a layer (or is the binary).
    let crates: BTreeSet<String> = std::fs::read_dir(root().join("crates"))
        .unwrap()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    let layered: BTreeSet<String> = LAYERS.iter().map(|(n, _)| n.to_string()).collect();
    assert_eq!(crates, layered);
}

/// The code of `text` before its first `#[cfg(test)]` (a file's tests come last), or none
/// for a file of tests.
fn outside_tests(path: &Path, text: &str) -> String {
    if path
        .file_name()
        .is_some_and(|n| n == "tests.rs" || n == "testing.rs")
    {
        return String::new();
    }
    text.split("#[cfg(test)]").next().unwrap_or("").to_string()
}

#[test]
fn no_source_file_is_over_the_limit_outside_its_tests() {
    let mut files = rust_files(&root().join("src"));
    for (name, _) in LAYERS {
        files.extend(rust_files(&root().join("crates").join(name).join("src")));
    }
    assert!(files.len() > 100, "{} files", files.len());
    for file in files {
        let text = std::fs::read_to_string(&file).unwrap();
        let lines = outside_tests(&file, &text).lines().count();
        assert!(
            lines <= MAX_LINES,
            "{} holds {lines} lines outside its tests (at most {MAX_LINES})",
            file.display()
        );
    }
}

#[test]
fn no_command_imports_another() {
    for command in COMMANDS {
        let file = root().join("src/cli").join(format!("{command}.rs"));
        let text = std::fs::read_to_string(&file).unwrap();
        for other in COMMANDS.iter().filter(|c| **c != command) {
            for path in [format!("super::{other}::"), format!("cli::{other}::")] {
                assert!(
                    !text.contains(&path),
                    "cli/{command}.rs imports cli/{other}.rs ({path})"
                );
            }
        }
    }
}

/// The names of the items `text` declares `pub` (exactly: not `pub(crate)` or
/// `pub(super)`), outside its tests: functions, types, traits, constants, statics, modules,
/// fields and re-exports.
fn pub_items(text: &str) -> Vec<String> {
    let mut out = Vec::new();
    for line in text.lines() {
        let line = line.trim_start();
        let Some(rest) = line.strip_prefix("pub ") else {
            continue;
        };
        let rest = rest
            .trim_start_matches("const fn ")
            .trim_start_matches("unsafe fn ")
            .trim_start_matches("async fn ");
        let word = |s: &str| -> Option<String> {
            let name: String = s
                .chars()
                .take_while(|c| c.is_alphanumeric() || *c == '_')
                .collect();
            (!name.is_empty()).then_some(name)
        };
        let name = [
            "fn ", "struct ", "enum ", "trait ", "const ", "static ", "type ", "mod ",
        ]
        .iter()
        .find_map(|k| rest.strip_prefix(k).and_then(word))
        // A field: `pub name: Type`.
        .or_else(|| {
            rest.split_once(':')
                .and_then(|(n, _)| word(n).filter(|w| w == n))
        });
        out.extend(name);
        // `pub use a::{B, c as d};`: the names it exports.
        if let Some(tree) = rest.strip_prefix("use ") {
            let inner = tree
                .rsplit_once('{')
                .map_or(tree, |(_, t)| t)
                .trim_end_matches(['}', ';']);
            for part in inner.split(',') {
                let last = part.trim().rsplit([' ', ':']).next().unwrap_or("");
                out.extend(word(last).filter(|w| w != "self"));
            }
        }
    }
    out
}

/// The signatures of the `pub` declarations of `text` outside its tests: each from `pub ` to
/// the first `{` or `;` (a function's parameters and result, a field's type), and a trait's
/// whole body (its methods' signatures): what another crate sees of them.
fn pub_signatures(text: &str) -> Vec<&str> {
    text.match_indices("pub ")
        .filter(|(i, _)| {
            text[..*i]
                .chars()
                .next_back()
                .is_none_or(char::is_whitespace)
        })
        .map(|(i, _)| {
            let rest = &text[i..];
            let end = match rest.starts_with("pub trait ") {
                true => rest.find("\n}").unwrap_or(rest.len()),
                false => rest.find(['{', ';']).unwrap_or(rest.len()),
            };
            &rest[..end]
        })
        .collect()
}

/// Whether `word` stands in `text` as a whole word.
fn names(text: &str, word: &str) -> bool {
    text.match_indices(word).any(|(i, _)| {
        let before = text[..i].chars().next_back();
        let after = text[i + word.len()..].chars().next();
        let part = |c: Option<char>| c.is_some_and(|c| c.is_alphanumeric() || c == '_');
        !part(before) && !part(after)
    })
}

#[test]
fn every_pub_item_of_a_library_crate_is_named_outside_it() {
    let all: Vec<(String, String)> = ["src", "tests", "examples", "crates"]
        .iter()
        .flat_map(|d| rust_files(&root().join(d)))
        .map(|p| {
            let text = std::fs::read_to_string(&p).unwrap();
            (p.to_string_lossy().into_owned(), text)
        })
        .collect();
    let mut unused = Vec::new();
    for (name, _) in LAYERS {
        let own = root().join("crates").join(name).join("src");
        let own = own.to_string_lossy();
        let outside: String = all
            .iter()
            .filter(|(p, _)| !p.starts_with(&*own))
            .map(|(_, t)| t.as_str())
            .collect::<Vec<_>>()
            .join("\n");
        let code: Vec<(&String, String)> = all
            .iter()
            .filter(|(p, _)| p.starts_with(&*own))
            .map(|(p, t)| (p, outside_tests(Path::new(p), t)))
            .collect();
        let signatures: Vec<&str> = code.iter().flat_map(|(_, c)| pub_signatures(c)).collect();
        for (path, text) in &code {
            if path.ends_with("lib.rs") {
                continue;
            }
            for item in pub_items(text) {
                // In the signature of another item: not the item's own declaration.
                let in_interface = signatures.iter().any(|s| {
                    names(s, &item) && pub_items(s).first().is_none_or(|own| *own != item)
                });
                if !names(&outside, &item) && !in_interface {
                    unused.push(format!("{path}: {item}"));
                }
            }
        }
    }
    assert!(
        unused.is_empty(),
        "pub items named nowhere outside their crate (make them pub(crate), or remove \
         them):\n{}",
        unused.join("\n")
    );
}

#[test]
fn the_pub_item_scanner_finds_what_it_is_shown() {
    let text = "pub fn a() {}\npub(crate) fn b() {}\n    pub struct C {\n    pub d: u32,\n}\npub use x::{E, f as g};\npub const H: u32 = 1;\n";
    assert_eq!(pub_items(text), ["a", "C", "d", "E", "g", "H"]);
    let signatures = pub_signatures("pub fn a(x: B) -> C { pub d: E; }\nfn pub_f() {}");
    assert_eq!(signatures, ["pub fn a(x: B) -> C ", "pub d: E"]);
    assert!(names("x(a) + ab", "a"));
    assert!(!names("ab + ba", "a"));
}
