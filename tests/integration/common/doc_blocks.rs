//! The command blocks of a Markdown page, as `tests/integration/docs.rs` runs them: every
//! fenced block whose info string starts with `sh`, with what its info string asks and the
//! output quoted right after it.
//!
//! The info string after `sh` holds, in any order:
//! - `needs=NAME,...`: what the block needs beyond the binary (`gpu`, `slurm`, `ffmpeg`,
//!   `lmp`, `hyperfine`, `oiiotool`, `time`): without it the block is skipped, except under CI=true;
//! - `exit=N`: every `raytrace` the block runs exits N (default 0, and then the whole block
//!   must succeed);
//! - `serves=SECONDS`: the block serves until stopped; it is interrupted (SIGINT, as Ctrl-C
//!   does) after SECONDS, and every `raytrace` in it must then exit 130;
//! - `skip: REASON`: the rest of the line says why the block cannot run from a checkout (it
//!   builds or tests the project, or runs on another machine); it is not run.
//!
//! A fenced `text` block that follows an `sh` block (blank lines between at most) is the
//! output it quotes.

/// One `sh` block of a page.
#[derive(Debug, Clone)]
pub(crate) struct Block {
    /// The page's line of the opening fence (1-based).
    pub line: usize,
    /// What the block needs beyond the binary.
    pub needs: Vec<String>,
    /// The status every `raytrace` in it exits with.
    pub exit: i32,
    /// How long it runs before it is interrupted, for a block that serves until stopped.
    pub serves: Option<u32>,
    /// Why it is not run, where it is not.
    pub skip: Option<String>,
    /// The block's text: a bash script.
    pub script: String,
    /// The quoted output's lines, where a `text` block follows.
    pub quoted: Option<Vec<String>>,
}

/// A fenced block (indented in a list, or not): its info string, its opening line and its
/// lines, their indentation removed.
struct Fence {
    info: String,
    line: usize,
    body: Vec<String>,
    /// The index of the line after its closing fence.
    end: usize,
}

/// The fenced block that opens at `lines[start]`, if one does.
fn fence_at(lines: &[&str], start: usize) -> Option<Fence> {
    let info = lines[start]
        .trim_start()
        .strip_prefix("```")?
        .trim()
        .to_string();
    let close = (start + 1..lines.len()).find(|&i| lines[i].trim() == "```")?;
    Some(Fence {
        info,
        line: start + 1,
        body: lines[start + 1..close]
            .iter()
            .map(|l| l.trim_start().to_string())
            .collect(),
        end: close + 1,
    })
}

/// Every `sh` block of `page`, in order; panics on an info string it does not know.
pub(crate) fn sh_blocks(page: &str) -> Vec<Block> {
    let lines: Vec<&str> = page.lines().collect();
    let mut blocks = Vec::new();
    let mut i = 0;
    while i < lines.len() {
        let Some(fence) = fence_at(&lines, i) else {
            i += 1;
            continue;
        };
        i = fence.end;
        let Some(rest) = fence.info.strip_prefix("sh") else {
            continue;
        };
        let mut block = parse_info(rest, fence.line);
        block.script = fence.body.join("\n");
        let next = (i..lines.len()).find(|&j| !lines[j].trim().is_empty());
        let quote = next.and_then(|j| fence_at(&lines, j));
        if let Some(quote) = quote.filter(|q| q.info == "text") {
            block.quoted = Some(quote.body);
            i = quote.end;
        }
        blocks.push(block);
    }
    blocks
}

/// A block with the settings of its info string after `sh`.
fn parse_info(rest: &str, line: usize) -> Block {
    let (words, skip) = match rest.split_once("skip:") {
        Some((w, reason)) => (w, Some(reason.trim().to_string())),
        None => (rest, None),
    };
    assert!(
        skip.as_ref().is_none_or(|r| !r.is_empty()),
        "line {line}: `skip:` without a reason"
    );
    let mut block = Block {
        line,
        needs: Vec::new(),
        exit: 0,
        serves: None,
        skip,
        script: String::new(),
        quoted: None,
    };
    for word in words.split_whitespace() {
        match word.split_once('=') {
            Some(("needs", list)) => block.needs = list.split(',').map(String::from).collect(),
            Some(("exit", n)) => block.exit = n.parse().expect("exit=N"),
            Some(("serves", n)) => {
                block.serves = Some(n.parse().expect("serves=SECONDS"));
                block.exit = 130;
            }
            _ => panic!("line {line}: unknown `{word}` in an sh block's info string"),
        }
    }
    block
}

#[test]
fn blocks_their_settings_and_quotes_are_read() {
    let page = "intro\n```sh\nraytrace check a.toml\n```\n\n```text\nchunks: 3\n```\n\
                ```sh needs=gpu,lmp exit=2\nx\n```\nprose\n```text\nnot quoted\n```\n\
                ```toml\n[shot]\n```\n```sh skip: on another machine\nssh node\n```\n```sh serves=3\nraytrace preview a.toml\n```\n";
    let b = sh_blocks(page);
    assert_eq!(b.len(), 4);
    assert_eq!((b[0].line, b[0].exit), (2, 0));
    assert_eq!(b[0].script, "raytrace check a.toml");
    assert_eq!(b[0].quoted, Some(vec!["chunks: 3".to_string()]));
    assert_eq!(
        (b[1].needs.clone(), b[1].exit),
        (vec!["gpu".into(), "lmp".into()], 2)
    );
    assert_eq!(b[1].quoted, None);
    assert_eq!(b[2].skip.as_deref(), Some("on another machine"));
    assert_eq!((b[3].serves, b[3].exit), (Some(3), 130));
}

#[test]
#[should_panic(expected = "unknown `needz=gpu`")]
fn an_unknown_setting_is_refused() {
    sh_blocks("```sh needz=gpu\nx\n```\n");
}
