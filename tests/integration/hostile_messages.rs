//! Hostile names and settings: frame patterns that cannot be formatted, scenes the GPU
//! refuses, memory refusals and control characters in file names. Each run ends within 5
//! seconds under a 1 GiB address-space limit, exits 2 with a message that names the file and
//! the key or option, and writes nothing.

use crate::common;

use common::hostile::{points, refused, run, scene, setup};
use common::text;

#[test]
fn frame_patterns_that_cannot_be_formatted_are_refused_naming_the_key() {
    // 65,536 `#`: one more than the widest field Rust's formatting takes (it panicked), and
    // far more than a file name holds.
    let run_of = "#".repeat(65_536);
    let wide = format!("f_{run_of}.png");
    let d = setup(&scene(&wide, ""), &[]);
    for command in ["render", "check"] {
        refused(
            d.path(),
            &[command, "shot.toml"],
            &["shot.toml: output.path", "65536 '#'"],
            &["shot.toml"],
        );
    }
    let d = setup(&scene("f_####.png", ""), &[]);
    refused(
        d.path(),
        &["render", "shot.toml", "--output", &wide],
        &["--output \"f_###", "65536 '#'"],
        &["shot.toml"],
    );
    let d = setup(
        &scene("f_####.png", &points(&format!("p_{run_of}.ply"), "")),
        &[],
    );
    for command in ["render", "check"] {
        refused(
            d.path(),
            &[command, "shot.toml"],
            &["shot.toml: points[0].file", "65536 '#'"],
            &["shot.toml"],
        );
    }
    let d = setup(&scene("f_####.png", ""), &[]);
    refused(
        d.path(),
        &["clip", "shot.toml", "c.gif", "--input", &wide],
        &["--input", "65536 '#'"],
        &["shot.toml"],
    );
    refused(
        d.path(),
        &[
            "generate",
            "-o",
            &format!("p_{run_of}.ply"),
            "--frames",
            "2",
        ],
        &["--output", "65536 '#'"],
        &["shot.toml"],
    );
    // A run as wide as a file name can hold is formatted: the name it makes is then refused
    // for what it is, 2 bytes too long.
    let d = setup(&scene(&format!("{}.png", "#".repeat(253)), ""), &[]);
    refused(
        d.path(),
        &["check", "shot.toml"],
        &[&format!("{}1.png\" is 257 bytes long", "0".repeat(252))],
        &["shot.toml"],
    );
    // Narrower runs render.
    let d = setup(&scene(&format!("f_{}.png", "#".repeat(200)), ""), &[]);
    let o = run(d.path(), &["render", "shot.toml", "--frames", "2"]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let name = format!("f_{}2.png", "0".repeat(199));
    assert!(d.path().join(name).is_file());
}

#[test]
fn gpu_refusals_name_the_scene_file() {
    let tiny = "[[sphere]]\ncenter = [0.0, 0.0, -1.0]\nradius = 1e-30\n\
                material = { type = \"lambertian\", albedo = [0.5, 0.5, 0.5] }\n";
    let d = setup(&scene("f_####.png", tiny), &[]);
    for command in ["render", "check"] {
        refused(
            d.path(),
            &[command, "shot.toml", "--device", "gpu"],
            &["shot.toml: --device gpu: ", "sphere[1].radius"],
            &["shot.toml"],
        );
    }
}

#[test]
fn a_memory_refusal_names_the_scene_file() {
    let d = setup(&scene("f_####.exr", ""), &[]);
    refused(
        d.path(),
        &[
            "render",
            "shot.toml",
            "--width",
            "65536",
            "--height",
            "65536",
        ],
        &["shot.toml: a frame of 65536x65536 pixels", "needs about"],
        &["shot.toml"],
    );
    let big =
        scene("f_####.exr", "").replace("width = 8\nheight = 6", "width = 65536\nheight = 65536");
    let d = setup(&big, &[]);
    refused(
        d.path(),
        &["check", "shot.toml"],
        &["shot.toml: a frame of 65536x65536 pixels", "needs about"],
        &["shot.toml"],
    );
}

#[test]
fn control_characters_of_a_file_name_are_escaped_in_messages() {
    // A cache named with the terminal's escape sequence for red text, a bell and a line
    // feed: none of them reaches the terminal as it is.
    let name = "p\u{1b}[31m\u{7}\n.ply";
    let d = setup(
        &scene("f_####.png", &points("p\\u001B[31m\\u0007\\n.ply", "")),
        &[],
    );
    let t = refused(
        d.path(),
        &["check", "shot.toml"],
        &["p\\u{1b}[31m\\u{7}\\n.ply", "No such file"],
        &["shot.toml"],
    );
    assert!(!t.contains('\u{1b}') && !t.contains('\u{7}'), "{t:?}");
    assert!(!t.contains(name), "{t:?}");
    // A scene file's own name.
    let t = refused(
        d.path(),
        &["check", "s\u{1b}]0;title\u{7}.toml"],
        &["s\\u{1b}]0;title\\u{7}.toml", "No such file"],
        &["shot.toml"],
    );
    assert!(!t.contains('\u{1b}') && !t.contains('\u{7}'), "{t:?}");
}
