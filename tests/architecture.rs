//! The house's rules, checked on the source itself (docs/architecture.md states them):
//! - the imports between the files of `src/` form no circle;
//! - no file holds more than 700 lines outside its tests;
//! - no command module (`cli/render`, `check`, `clip`, `converge`, `generate`, `preview`)
//!   imports another;
//! - no file imports one on a higher floor ([`FLOORS`]): nothing points back up.
//!
//! A file imports another when it names an item through a path that resolves into that
//! file's module: `crate::a::b::Item`, `super::sibling::Item`, a `use` tree's branches, or a
//! child module declared in the file. Code under `#[cfg(test)]` does not count, nor does the
//! crate root (`lib.rs`, `main.rs`), which only declares modules. The same analysis is first
//! run on small made-up trees whose answers are known.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// Largest number of lines outside tests a file of `src/` may hold.
const MAX_LINES: usize = 700;

/// The command modules, which must not import one another.
const COMMANDS: [&str; 6] = [
    "cli/render.rs",
    "cli/check.rs",
    "cli/clip.rs",
    "cli/converge.rs",
    "cli/generate.rs",
    "cli/preview.rs",
];

/// The floors of the house, lowest first, as docs/architecture.md draws them: each file is on
/// the floor of the longest prefix of its path listed here, and imports only from its own
/// floor or those below.
const FLOORS: [(&str, u32); 48] = [
    // 0. leaves
    ("error.rs", 0),
    ("format.rs", 0),
    ("path_pattern.rs", 0),
    ("analysis/metrics.rs", 0),
    ("analysis/fit.rs", 0),
    ("analysis/flip.rs", 0),
    ("analysis/stats.rs", 0),
    ("analysis/mod.rs", 0),
    // 1. the core
    ("shutter.rs", 1),
    ("shutter_curve.rs", 1),
    ("motion.rs", 1),
    ("lerp.rs", 1),
    ("aabb.rs", 1),
    ("sphere.rs", 1),
    ("hit.rs", 1),
    ("ray.rs", 1),
    ("bvh", 1),
    ("camera.rs", 1),
    ("material.rs", 1),
    ("sampler.rs", 1),
    ("rng.rs", 1),
    ("trig.rs", 1),
    ("pass.rs", 1),
    ("replicates.rs", 1),
    ("denoise/", 1),
    ("points.rs", 1),
    ("traced_points.rs", 1),
    ("colormap.rs", 1),
    // 2. the description
    ("scene.rs", 2),
    // 3. the frame
    ("world.rs", 3),
    ("prepared.rs", 3),
    ("renderer/", 3),
    ("tracer.rs", 3),
    ("passes.rs", 3),
    ("film.rs", 3),
    ("gpu/", 3),
    // 4. files
    ("scene_file/", 4),
    ("output.rs", 4),
    ("io/", 4),
    ("clip/", 4),
    ("memory.rs", 4),
    ("analysis/plot.rs", 4),
    ("ply/", 4),
    ("point_cache/", 4),
    ("sim/", 4),
    ("fountain.rs", 4),
    ("preview/", 4),
    // 5. commands
    ("cli/", 5),
];

/// The floor of `file`, or `None` for a file no floor lists.
fn floor(file: &str) -> Option<u32> {
    FLOORS
        .iter()
        .filter(|(prefix, _)| file.starts_with(prefix))
        .max_by_key(|(prefix, _)| prefix.len())
        .map(|&(_, f)| f)
}

/// A source tree: each file (relative path, `/`-separated) with its text.
type Tree = BTreeMap<String, String>;

fn read_tree(root: &Path) -> Tree {
    fn walk(dir: &Path, root: &Path, out: &mut Tree) {
        for entry in std::fs::read_dir(dir).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                walk(&path, root, out);
            } else if path.extension().is_some_and(|e| e == "rs") {
                let rel = path.strip_prefix(root).unwrap();
                let rel = rel.to_string_lossy().replace('\\', "/");
                out.insert(rel, std::fs::read_to_string(&path).unwrap());
            }
        }
    }
    let mut tree = Tree::new();
    walk(root, root, &mut tree);
    tree
}

/// The module path of a file: `a/b.rs` and `a/b/mod.rs` are `[a, b]`; `lib.rs` is `[]`.
fn module_of(file: &str) -> Vec<String> {
    let mut parts: Vec<String> = file
        .trim_end_matches(".rs")
        .split('/')
        .map(String::from)
        .collect();
    if matches!(
        parts.last().map(String::as_str),
        Some("mod" | "lib" | "main")
    ) {
        parts.pop();
    }
    parts
}

/// The text with comments, string and char literals blanked (so that paths inside them do not
/// count) and every `#[cfg(test)]` item removed (a `mod tests { ... }` block, or a
/// `mod tests;` declaration, whose file is then skipped by its name).
fn code_of(text: &str) -> String {
    let b = text.as_bytes();
    let mut out = String::with_capacity(text.len());
    let mut i = 0;
    while i < b.len() {
        if b[i..].starts_with(b"//") {
            while i < b.len() && b[i] != b'\n' {
                i += 1;
            }
        } else if b[i..].starts_with(b"/*") {
            let end = text[i + 2..].find("*/").map_or(b.len(), |e| i + 2 + e + 2);
            i = end;
        } else if b[i] == b'"'
            || (b[i] == b'r'
                && b.get(i + 1).is_some_and(|&c| c == b'"' || c == b'#')
                && !prev_is_ident(b, i))
        {
            i = skip_string(b, i);
            out.push_str("\"\"");
        } else if b[i] == b'\'' && is_char_literal(b, i) {
            i = skip_char(b, i);
            out.push_str("' '");
        } else {
            out.push(b[i] as char);
            i += 1;
        }
    }
    remove_test_items(&out)
}

fn prev_is_ident(b: &[u8], i: usize) -> bool {
    i > 0 && (b[i - 1].is_ascii_alphanumeric() || b[i - 1] == b'_')
}

/// Skips a string literal (plain or raw) starting at `i`; returns the index after it.
fn skip_string(b: &[u8], mut i: usize) -> usize {
    if b[i] == b'r' {
        i += 1;
        let mut hashes = 0;
        while b[i] == b'#' {
            hashes += 1;
            i += 1;
        }
        i += 1; // the quote
        loop {
            if i >= b.len() {
                return i;
            }
            if b[i] == b'"'
                && b[i + 1..]
                    .iter()
                    .take(hashes)
                    .filter(|&&c| c == b'#')
                    .count()
                    == hashes
            {
                return i + 1 + hashes;
            }
            i += 1;
        }
    }
    i += 1;
    while i < b.len() {
        match b[i] {
            b'\\' => i += 2,
            b'"' => return i + 1,
            _ => i += 1,
        }
    }
    i
}

/// Whether the quote at `i` starts a char literal (`'a'`, `'\n'`) rather than a lifetime.
fn is_char_literal(b: &[u8], i: usize) -> bool {
    match b.get(i + 1) {
        Some(b'\\') => true,
        Some(_) => {
            // One character (possibly multi-byte) then a quote.
            let s = std::str::from_utf8(&b[i + 1..]).ok();
            let s = s.or_else(|| std::str::from_utf8(&b[i + 1..(i + 5).min(b.len())]).ok());
            s.and_then(|s| s.chars().next())
                .is_some_and(|c| b.get(i + 1 + c.len_utf8()) == Some(&b'\''))
        }
        None => false,
    }
}

fn skip_char(b: &[u8], mut i: usize) -> usize {
    i += 1;
    if b[i] == b'\\' {
        i += 2;
    }
    while i < b.len() && b[i] != b'\'' {
        i += 1;
    }
    i + 1
}

/// Removes each `#[cfg(test)]` attribute and the item after it (to its matching `}` or `;`).
fn remove_test_items(code: &str) -> String {
    let mut out = String::new();
    let mut rest = code;
    while let Some(at) = rest.find("#[cfg(test)]") {
        out.push_str(&rest[..at]);
        let after = &rest[at..];
        let brace = after.find('{');
        let semi = after.find(';');
        let end = match (brace, semi) {
            (Some(b), Some(s)) if s < b => s + 1,
            (Some(b), _) => {
                let mut depth = 0;
                let mut end = after.len();
                for (k, c) in after[b..].char_indices() {
                    match c {
                        '{' => depth += 1,
                        '}' => {
                            depth -= 1;
                            if depth == 0 {
                                end = b + k + 1;
                                break;
                            }
                        }
                        _ => {}
                    }
                }
                end
            }
            (None, Some(s)) => s + 1,
            (None, None) => after.len(),
        };
        rest = &after[end..];
    }
    out.push_str(rest);
    out
}

/// Lines of a file outside its `#[cfg(test)]` items.
fn lines_outside_tests(text: &str) -> usize {
    remove_test_items(text).trim_end().lines().count()
}

/// The paths a file names: each `use` tree expanded to its branches, and every other path
/// that starts with `crate`, `super`, `self` or one of the file's declared child modules.
fn paths_in(code: &str, children: &BTreeSet<String>) -> Vec<Vec<String>> {
    let mut paths = Vec::new();
    // `use` trees.
    let mut rest = code;
    let mut outside_use = String::new();
    while let Some(at) = find_word(rest, "use") {
        outside_use.push_str(&rest[..at]);
        let tail = &rest[at + 3..];
        let end = tail.find(';').unwrap_or(tail.len());
        expand_use(&tail[..end], &mut Vec::new(), &mut paths);
        rest = &tail[(end + 1).min(tail.len())..];
    }
    outside_use.push_str(rest);
    // Other paths.
    let tokens: Vec<&str> = outside_use
        .split(|c: char| !(c.is_alphanumeric() || c == '_' || c == ':'))
        .filter(|t| t.contains("::"))
        .collect();
    for t in tokens {
        let segs: Vec<String> = t
            .split("::")
            .filter(|s| !s.is_empty())
            .map(String::from)
            .collect();
        if let Some(first) = segs.first()
            && (matches!(first.as_str(), "crate" | "super" | "self") || children.contains(first))
            && !t.starts_with("::")
        {
            paths.push(segs);
        }
    }
    paths
}

/// The index of `word` in `text` as a whole word, if any.
fn find_word(text: &str, word: &str) -> Option<usize> {
    let b = text.as_bytes();
    let mut from = 0;
    while let Some(k) = text[from..].find(word) {
        let at = from + k;
        let before = at == 0 || !(b[at - 1].is_ascii_alphanumeric() || b[at - 1] == b'_');
        let after = b
            .get(at + word.len())
            .is_none_or(|c| c.is_ascii_whitespace());
        if before && after {
            return Some(at);
        }
        from = at + word.len();
    }
    None
}

/// Expands a `use` tree (`a::{b, c::{d, e}}`) into its paths, each prefixed by `prefix`.
fn expand_use(tree: &str, prefix: &mut Vec<String>, out: &mut Vec<Vec<String>>) {
    let tree = tree.trim();
    if let Some(open) = tree.find('{') {
        let head: Vec<String> = tree[..open]
            .split("::")
            .map(str::trim)
            .filter(|s| !s.is_empty())
            .map(String::from)
            .collect();
        let close = tree.rfind('}').unwrap_or(tree.len());
        let inner = &tree[open + 1..close];
        let n = prefix.len();
        prefix.extend(head);
        for branch in split_top_level(inner) {
            expand_use(branch, prefix, out);
        }
        prefix.truncate(n);
    } else {
        let name = tree.split(" as ").next().unwrap_or(tree).trim();
        if name.is_empty() {
            return;
        }
        let mut path = prefix.clone();
        path.extend(
            name.split("::")
                .map(str::trim)
                .filter(|s| !s.is_empty())
                .map(String::from),
        );
        out.push(path);
    }
}

/// `a, b::{c, d}, e` split at the commas outside braces.
fn split_top_level(text: &str) -> Vec<&str> {
    let mut parts = Vec::new();
    let (mut depth, mut start) = (0, 0);
    for (i, c) in text.char_indices() {
        match c {
            '{' => depth += 1,
            '}' => depth -= 1,
            ',' if depth == 0 => {
                parts.push(&text[start..i]);
                start = i + 1;
            }
            _ => {}
        }
    }
    parts.push(&text[start..]);
    parts
}

/// The import graph of a tree: for each file (test files and the root excluded), the files
/// it imports.
fn imports(tree: &Tree) -> BTreeMap<String, BTreeSet<String>> {
    let modules: BTreeMap<Vec<String>, String> =
        tree.keys().map(|f| (module_of(f), f.clone())).collect();
    let is_root = |f: &str| f == "lib.rs" || f == "main.rs";
    let is_test = |f: &str| f == "tests.rs" || f.ends_with("/tests.rs");
    let mut graph = BTreeMap::new();
    for (file, text) in tree {
        if is_root(file) || is_test(file) {
            continue;
        }
        let code = code_of(text);
        let me = module_of(file);
        let children: BTreeSet<String> = code
            .split(';')
            .filter_map(|s| {
                let s = s.trim();
                let s = s
                    .strip_prefix("pub(crate) ")
                    .or(s.strip_prefix("pub "))
                    .unwrap_or(s);
                s.strip_prefix("mod ").map(|n| n.trim().to_string())
            })
            .filter(|n| n.chars().all(|c| c.is_alphanumeric() || c == '_'))
            .collect();
        let mut targets = BTreeSet::new();
        for path in paths_in(&code, &children) {
            let mut base: Vec<String>;
            let mut segs = path.as_slice();
            match segs[0].as_str() {
                "crate" => {
                    base = Vec::new();
                    segs = &segs[1..];
                }
                "self" => {
                    base = me.clone();
                    segs = &segs[1..];
                }
                "super" => {
                    base = me.clone();
                    while segs.first().is_some_and(|s| s == "super") {
                        base.pop();
                        segs = &segs[1..];
                    }
                }
                // A child module declared in this file; anything else (an extern crate,
                // `std`) is outside `src/`.
                first if children.contains(first) => base = me.clone(),
                _ => continue,
            }
            if segs.is_empty() {
                continue;
            }
            let mut full = base;
            full.extend(segs.iter().cloned());
            // The deepest module the path goes through.
            let target = (1..=full.len())
                .rev()
                .find_map(|k| modules.get(&full[..k]))
                .filter(|t| !is_root(t) && !is_test(t) && *t != file);
            if let Some(t) = target {
                targets.insert(t.clone());
            }
        }
        graph.insert(file.clone(), targets);
    }
    graph
}

/// The circles of a graph: its strongly connected components of more than one file.
fn circles(graph: &BTreeMap<String, BTreeSet<String>>) -> Vec<Vec<String>> {
    // Kosaraju: order by finish time, then collect on the reversed graph.
    let nodes: Vec<&String> = graph.keys().collect();
    let mut seen = BTreeSet::new();
    let mut order = Vec::new();
    for &n in &nodes {
        if seen.contains(n) {
            continue;
        }
        let mut stack = vec![(n, false)];
        while let Some((v, done)) = stack.pop() {
            if done {
                order.push(v);
                continue;
            }
            if !seen.insert(v) {
                continue;
            }
            stack.push((v, true));
            for w in graph.get(v).into_iter().flatten() {
                if !seen.contains(w) {
                    stack.push((w, false));
                }
            }
        }
    }
    let mut reversed: BTreeMap<&String, Vec<&String>> = BTreeMap::new();
    for (v, ws) in graph {
        for w in ws {
            reversed.entry(w).or_default().push(v);
        }
    }
    let mut assigned = BTreeSet::new();
    let mut out = Vec::new();
    for &v in order.iter().rev() {
        if assigned.contains(v) {
            continue;
        }
        let mut component = Vec::new();
        let mut stack = vec![v];
        assigned.insert(v);
        while let Some(x) = stack.pop() {
            component.push(x.clone());
            for &y in reversed.get(x).into_iter().flatten() {
                if assigned.insert(y) {
                    stack.push(y);
                }
            }
        }
        if component.len() > 1 {
            component.sort();
            out.push(component);
        }
    }
    out
}

fn made_up(files: &[(&str, &str)]) -> Tree {
    files
        .iter()
        .map(|(f, t)| (f.to_string(), t.to_string()))
        .collect()
}

#[test]
fn the_analysis_finds_circles_it_is_shown() {
    // A facade `mod.rs` whose child imports an item through it: a circle of two.
    let tree = made_up(&[
        ("lib.rs", "pub mod scene;\npub mod world;"),
        (
            "scene/mod.rs",
            "mod read;\npub use read::load;\npub struct Scene;",
        ),
        (
            "scene/read.rs",
            "use super::Scene;\npub fn load() -> Scene { Scene }",
        ),
        (
            "world.rs",
            "use crate::scene::{Scene, load};\n// use crate::world::X;\n",
        ),
    ]);
    let g = imports(&tree);
    assert_eq!(g["world.rs"], BTreeSet::from(["scene/mod.rs".to_string()]));
    assert_eq!(
        circles(&g),
        vec![vec![
            "scene/mod.rs".to_string(),
            "scene/read.rs".to_string()
        ]]
    );
    // Three files around, through `use` groups, `super::super` and a bare path.
    let tree = made_up(&[
        ("a.rs", "use crate::{b::{self, X}, c};\nfn f() { c::g(); }"),
        ("b.rs", "pub struct X; fn h() { let s = \"crate::a::Y\"; }"),
        ("c/mod.rs", "mod d;\npub fn g() { d::k(); }"),
        ("c/d.rs", "pub fn k() { super::super::a::f(); }"),
    ]);
    let g = imports(&tree);
    assert_eq!(g["b.rs"], BTreeSet::new(), "paths in strings do not count");
    assert_eq!(
        circles(&g),
        vec![vec![
            "a.rs".to_string(),
            "c/d.rs".to_string(),
            "c/mod.rs".to_string()
        ]]
    );
    // Test code does not count.
    let tree = made_up(&[
        (
            "a.rs",
            "use crate::b::X;\n#[cfg(test)]\nmod tests {\n    use crate::b::Y;\n}\n",
        ),
        (
            "b.rs",
            "pub struct X;\n#[cfg(test)]\nmod tests {\n    use crate::a::Z;\n}\n",
        ),
    ]);
    assert!(circles(&imports(&tree)).is_empty());
    assert_eq!(lines_outside_tests(&tree["b.rs"]), 1);
}

#[test]
fn the_imports_of_src_form_no_circle() {
    let tree = read_tree(&Path::new(env!("CARGO_MANIFEST_DIR")).join("src"));
    let graph = imports(&tree);
    assert!(graph.len() > 50, "the whole of src/ was read");
    let found = circles(&graph);
    // Each file of a circle with the files of the circle it imports.
    let arrows: Vec<(String, Vec<&String>)> = found
        .iter()
        .flat_map(|c| {
            c.iter()
                .map(|f| {
                    (
                        f.clone(),
                        graph[f].iter().filter(|t| c.contains(t)).collect(),
                    )
                })
                .collect::<Vec<_>>()
        })
        .collect();
    assert!(found.is_empty(), "import circles in src/: {arrows:#?}");
}

#[test]
fn no_file_of_src_is_over_700_lines_outside_its_tests() {
    let tree = read_tree(&Path::new(env!("CARGO_MANIFEST_DIR")).join("src"));
    let over: Vec<(String, usize)> = tree
        .iter()
        .filter(|(f, _)| !f.ends_with("tests.rs"))
        .map(|(f, t)| (f.clone(), lines_outside_tests(t)))
        .filter(|(_, n)| *n > MAX_LINES)
        .collect();
    assert!(over.is_empty(), "files over {MAX_LINES} lines: {over:?}");
}

#[test]
fn no_command_imports_another() {
    let tree = read_tree(&Path::new(env!("CARGO_MANIFEST_DIR")).join("src"));
    let graph = imports(&tree);
    let commands: BTreeSet<String> = COMMANDS
        .iter()
        .map(|c| PathBuf::from(c).to_string_lossy().into_owned())
        .collect();
    for c in &commands {
        let imported: Vec<&String> = graph[c].intersection(&commands).collect();
        assert!(imported.is_empty(), "{c} imports {imported:?}");
        assert!(
            !graph[c].contains("cli/mod.rs"),
            "{c} imports through cli/mod.rs"
        );
    }
}

#[test]
fn every_file_of_src_is_on_a_floor_and_no_import_points_up() {
    let tree = read_tree(&Path::new(env!("CARGO_MANIFEST_DIR")).join("src"));
    let graph = imports(&tree);
    let mut up = Vec::new();
    for (file, targets) in &graph {
        let from = floor(file).unwrap_or_else(|| panic!("{file} is on no floor of FLOORS"));
        for t in targets {
            let to = floor(t).unwrap_or_else(|| panic!("{t} is on no floor of FLOORS"));
            if to > from {
                up.push(format!("{file} (floor {from}) -> {t} (floor {to})"));
            }
        }
    }
    assert!(up.is_empty(), "imports that point up: {up:#?}");
}
