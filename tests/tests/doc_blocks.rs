//! Every ```` ```sh ```` block of README.md, docs/*.md and */README.md runs
//! as written, or says why not (issue 46, "What to build" 6).
//!
//! A block is run with `bash -e` in a fresh temporary directory (its own
//! working directory, `HOME` and `tmp/`) and must exit 0. The only changes
//! to it, all made here and nowhere else:
//! - `anguilla` is this build's binary (a `bin/anguilla` link first on
//!   `PATH`), and `cargo run --release --` is `anguilla`;
//! - a `/tmp/...` path is `<the directory>/tmp/...`;
//! - the example recording `/var/lib/anguilla/session-NNN` is a session
//!   this test records first with the built-in robot (`anguilla run
//!   --duration`).
//!
//! Whatever the block leaves running (a daemon started with `&`) is sent
//! SIGINT when it ends, then SIGKILL. A marker on the line just before the
//! fence says more:
//! - `<!-- not run by tests: REASON -->`: not run (a CAN adapter, root, a
//!   VM, a second computer, a long build, or run by another test or
//!   script). The reason must not be empty; a script it names
//!   (`scripts/NAME`) must exist and be run by `.ci/run`; a test it names
//!   (`tests/tests/FILE.rs FUNCTION`) must exist; a block it says is "the
//!   same as README.md's" must be one of README.md's blocks word for word.
//! - `<!-- tests expect: "TEXT" "TEXT" -->`: run, and each TEXT must
//!   appear in its output (stdout and stderr) or name a file it made.
//!
//! The test fails listing (file:line) every block with neither a marker
//! nor a run that passed, and every marker without a reason.

use std::fs::File;
use std::os::unix::process::CommandExt;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::Duration;

use anguilla_system_tests::Watchdog;
use anguilla_system_tests::process::anguilla_bin;
use anguilla_testkit::Deadline;

/// The workspace's root.
fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// One ```` ```sh ```` block.
#[derive(Debug)]
struct Block {
    /// `path:line` of its fence, the path relative to the workspace.
    at: String,
    /// Its text, without the fences.
    text: String,
    /// The line just before the fence.
    before: String,
}

/// What the line before a block says.
#[derive(Debug, PartialEq)]
enum Marker {
    /// `<!-- not run by tests: REASON -->`
    NotRun(String),
    /// `<!-- tests expect: "A" "B" -->`
    Expect(Vec<String>),
    /// Anything else: run, exit 0 expected.
    None,
}

const NOT_RUN: &str = "<!-- not run by tests:";
const EXPECT: &str = "<!-- tests expect:";

fn marker(line: &str) -> Result<Marker, String> {
    let line = line.trim();
    let body = |rest: &str| -> Result<String, String> {
        rest.strip_suffix("-->")
            .map(|r| r.trim().to_string())
            .ok_or_else(|| format!("a marker on one line, ending in '-->': {line}"))
    };
    if let Some(rest) = line.strip_prefix(NOT_RUN) {
        let reason = body(rest)?;
        if reason.is_empty() {
            return Err("a 'not run by tests' marker with no reason".into());
        }
        Ok(Marker::NotRun(reason))
    } else if let Some(rest) = line.strip_prefix(EXPECT) {
        let texts: Vec<String> = body(rest)?
            .split('"')
            .skip(1)
            .step_by(2)
            .map(str::to_string)
            .collect();
        if texts.is_empty() || texts.iter().any(String::is_empty) {
            return Err(format!(
                "a 'tests expect' marker without \"quoted\" texts: {line}"
            ));
        }
        Ok(Marker::Expect(texts))
    } else if line.starts_with("<!--") && line.contains("run by test") {
        Err(format!(
            "a marker the test does not read (expected '{NOT_RUN} REASON -->' or '{EXPECT} \"TEXT\" -->'): {line}"
        ))
    } else {
        Ok(Marker::None)
    }
}

/// Every ```` ```sh ```` block of README.md, docs/*.md and */README.md.
fn blocks() -> Vec<Block> {
    let root = root();
    let mut files = vec![PathBuf::from("README.md")];
    let mut docs: Vec<PathBuf> = std::fs::read_dir(root.join("docs"))
        .unwrap()
        .flatten()
        .map(|e| PathBuf::from("docs").join(e.file_name()))
        .filter(|p| p.extension().is_some_and(|e| e == "md"))
        .collect();
    let mut readmes: Vec<PathBuf> = std::fs::read_dir(&root)
        .unwrap()
        .flatten()
        .filter(|e| e.path().join("README.md").is_file())
        .map(|e| PathBuf::from(e.file_name()).join("README.md"))
        .collect();
    docs.sort();
    readmes.sort();
    files.extend(docs);
    files.extend(readmes);
    let mut out = Vec::new();
    for f in files {
        let text = std::fs::read_to_string(root.join(&f)).unwrap();
        let lines: Vec<&str> = text.lines().collect();
        let mut i = 0;
        while i < lines.len() {
            if lines[i].trim_end() == "```sh" {
                let end = (i + 1..lines.len())
                    .find(|&j| lines[j].trim_start().starts_with("```"))
                    .unwrap_or_else(|| panic!("{}:{}: an unclosed block", f.display(), i + 1));
                out.push(Block {
                    at: format!("{}:{}", f.display(), i + 1),
                    text: lines[i + 1..end].join("\n") + "\n",
                    before: if i > 0 {
                        lines[i - 1].to_string()
                    } else {
                        String::new()
                    },
                });
                i = end;
            }
            i += 1;
        }
    }
    out
}

/// What a "not run" reason claims, checked: the scripts it names exist and
/// CI runs them, the tests it names exist, and a block "the same as
/// README.md's" is one.
fn check_reason(reason: &str, text: &str, readme: &[&Block]) -> Result<(), String> {
    let root = root();
    let ci = std::fs::read_to_string(root.join(".ci/run")).unwrap();
    let words: Vec<&str> = reason
        .split(|c: char| c.is_whitespace() || c == ',' || c == ';' || c == '(' || c == ')')
        .filter(|w| !w.is_empty())
        .collect();
    for (k, w) in words.iter().enumerate() {
        let w = w.trim_end_matches(['.', ':']);
        if w.starts_with("scripts/") {
            if !root.join(w).is_file() {
                return Err(format!("it names {w}, which does not exist"));
            }
            if !ci.contains(w) {
                return Err(format!("it names {w}, which .ci/run does not run"));
            }
        }
        if w.starts_with("tests/tests/") && w.ends_with(".rs") {
            let src =
                std::fs::read_to_string(root.join(w)).map_err(|e| format!("it names {w}: {e}"))?;
            let f = words.get(k + 1).map(|f| f.trim_end_matches(['.', ':']));
            match f {
                Some(f) if src.contains(&format!("fn {f}(")) => {}
                _ => {
                    return Err(format!(
                        "it names {w} but no test in it after the file's name"
                    ));
                }
            }
        }
    }
    if reason.contains("the same as README.md's") && !readme.iter().any(|b| b.text == text) {
        return Err(
            "it says it is the same as a README.md block, and no README.md block is".into(),
        );
    }
    Ok(())
}

/// The directory a block runs in, and its environment.
struct Sandbox {
    dir: PathBuf,
}

impl Sandbox {
    fn new(tag: &str) -> Self {
        let dir = std::env::temp_dir().join(format!("anguilla-doc-{}-{tag}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        for d in ["bin", "home", "tmp", "work"] {
            std::fs::create_dir_all(dir.join(d)).unwrap();
        }
        let bin = std::fs::canonicalize(anguilla_bin())
            .unwrap_or_else(|e| panic!("{}: {e} (build it first)", anguilla_bin().display()));
        std::os::unix::fs::symlink(bin, dir.join("bin/anguilla")).unwrap();
        Self { dir }
    }

    /// Runs `script` with `bash -e` in its own process group; returns the
    /// exit code and the output (stdout and stderr). Whatever it leaves
    /// running gets SIGINT, then (after 10 s) SIGKILL.
    fn run(&self, script: &str, limit: Duration) -> (Option<i32>, String) {
        let out_path = self.dir.join("output");
        let out = File::create(&out_path).unwrap();
        let path = format!(
            "{}:{}",
            self.dir.join("bin").display(),
            std::env::var("PATH").unwrap_or_default()
        );
        let mut cmd = Command::new("bash");
        cmd.args(["-e", "-c", script])
            .current_dir(self.dir.join("work"))
            .env("HOME", self.dir.join("home"))
            .env("PATH", path)
            .stdin(Stdio::null())
            .stdout(out.try_clone().unwrap())
            .stderr(out);
        // SAFETY: setpgid is async-signal-safe; the child gets its own
        // process group, which is what is killed after it.
        unsafe {
            cmd.pre_exec(|| {
                libc::setpgid(0, 0);
                Ok(())
            });
        }
        let mut child = cmd.spawn().unwrap();
        let pgid = child.id() as i32;
        let deadline = Deadline::new(limit);
        let code = loop {
            if let Some(s) = child.try_wait().unwrap() {
                break s.code();
            }
            if deadline.passed() {
                // SAFETY: kill has no memory effects.
                unsafe { libc::kill(-pgid, libc::SIGKILL) };
                let _ = child.wait();
                break None;
            }
            std::thread::sleep(Duration::from_millis(50));
        };
        // What it left behind: SIGINT (a daemon stops smoothly), then
        // SIGKILL if it is still there 10 s on.
        // SAFETY: as above.
        unsafe { libc::kill(-pgid, libc::SIGINT) };
        let gone = Deadline::new(Duration::from_secs(10));
        // SAFETY: signal 0 only checks the group exists.
        while unsafe { libc::kill(-pgid, 0) } == 0 && !gone.passed() {
            std::thread::sleep(Duration::from_millis(50));
        }
        // SAFETY: as above.
        unsafe { libc::kill(-pgid, libc::SIGKILL) };
        let text = std::fs::read_to_string(&out_path).unwrap_or_default();
        (code, text)
    }
}

impl Drop for Sandbox {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.dir);
    }
}

/// A recording of the built-in robot, for the blocks that name the
/// example session: its `session-*` directory.
fn record(sandbox: &Sandbox) -> PathBuf {
    let rec = sandbox.dir.join("recordings");
    let cfg = sandbox.dir.join("rec.toml");
    std::fs::write(
        &cfg,
        format!("[recording]\ndir = {:?}\n", rec.to_str().unwrap()),
    )
    .unwrap();
    let (code, out) = sandbox.run(
        &format!(
            "anguilla run --config {} --duration 3 --quiet",
            cfg.display()
        ),
        anguilla_testkit::patient(Duration::from_secs(60)),
    );
    assert_eq!(code, Some(0), "recording a session: {out}");
    std::fs::read_dir(&rec)
        .unwrap()
        .flatten()
        .map(|e| e.path())
        .find(|p| {
            p.file_name()
                .unwrap()
                .to_string_lossy()
                .starts_with("session-")
        })
        .unwrap_or_else(|| panic!("no session in {}: {out}", rec.display()))
}

/// The block as run: the substitutions of the module's documentation.
fn as_run(text: &str, dir: &Path, session: &Path) -> String {
    let mut s = text
        .replace("cargo run --release --", "anguilla")
        .replace("/tmp/", &format!("{}/tmp/", dir.display()));
    let example = "/var/lib/anguilla/session-";
    while let Some(at) = s.find(example) {
        let digits = s[at + example.len()..]
            .find(|c: char| !c.is_ascii_digit())
            .unwrap_or(s.len() - at - example.len());
        s.replace_range(at..at + example.len() + digits, session.to_str().unwrap());
    }
    s
}

/// Runs one block; `Err` says why it failed.
fn run_block(block: &Block, expect: &[String], session: &Path) -> Result<(), String> {
    let tag = block.at.replace(['/', ':', '.'], "-");
    let sandbox = Sandbox::new(&tag);
    let script = as_run(&block.text, &sandbox.dir, session);
    let started = std::time::Instant::now();
    let (code, out) = sandbox.run(&script, anguilla_testkit::patient(Duration::from_secs(120)));
    eprintln!(
        "{}: exit {code:?} in {:.1} s",
        block.at,
        started.elapsed().as_secs_f64()
    );
    if code != Some(0) {
        return Err(format!("exit {code:?}:\n{script}\n--- output ---\n{out}"));
    }
    for e in expect {
        if !out.contains(e.as_str()) && !sandbox.dir.join("work").join(e).exists() {
            return Err(format!(
                "'{e}' not in its output nor a file it made:\n{out}"
            ));
        }
    }
    Ok(())
}

/// The parser and the runner find what they should: a block that fails
/// fails, a marker without a reason is refused, the substitutions apply.
#[test]
fn the_runner_tells_a_failing_block_from_a_passing_one() {
    assert_eq!(
        marker("<!-- not run by tests: a CAN adapter -->"),
        Ok(Marker::NotRun("a CAN adapter".into()))
    );
    assert!(marker("<!-- not run by tests:  -->").is_err());
    assert!(marker("<!-- not run by test, a CAN adapter -->").is_err());
    assert_eq!(
        marker(r#"<!-- tests expect: "34.5 % load" "a b" -->"#),
        Ok(Marker::Expect(vec!["34.5 % load".into(), "a b".into()]))
    );
    assert_eq!(marker("some prose."), Ok(Marker::None));
    let session = Path::new("/x/session-1");
    assert_eq!(
        as_run(
            "cargo run --release -- replay /var/lib/anguilla/session-1795322959 > /tmp/a\n",
            Path::new("/d"),
            session
        ),
        "anguilla replay /x/session-1 > /d/tmp/a\n"
    );
    let block = |text: &str| Block {
        at: "test:1".into(),
        text: text.into(),
        before: String::new(),
    };
    let ok = run_block(
        &block("anguilla --version\n"),
        &["anguilla".into()],
        session,
    );
    assert_eq!(ok, Ok(()));
    // -e: a failing line in the middle fails the block
    let err = run_block(&block("false\necho after\n"), &[], session).unwrap_err();
    assert!(err.starts_with("exit Some(1)"), "{err}");
    let err = run_block(&block("anguilla --version\n"), &["no such".into()], session).unwrap_err();
    assert!(err.contains("'no such' not in its output"), "{err}");
    assert!(check_reason("run in CI by scripts/no-such-script", "", &[]).is_err());
    assert!(check_reason("run by tests/tests/ctl.rs no_such_test", "", &[]).is_err());
}

#[test]
fn every_shell_block_in_the_docs_runs_as_written_or_says_why_not() {
    let _dog = Watchdog::new("doc-blocks", Duration::from_secs(600));
    let blocks = blocks();
    assert!(blocks.len() >= 40, "{} blocks found", blocks.len());
    let readme: Vec<&Block> = blocks
        .iter()
        .filter(|b| b.at.starts_with("README.md:"))
        .collect();
    let recorder = Sandbox::new("recording");
    let session = record(&recorder);
    let mut problems = Vec::new();
    let (mut ran, mut skipped) = (0, 0);
    for b in &blocks {
        let m = match marker(&b.before) {
            Ok(m) => m,
            Err(e) => {
                problems.push(format!("{}: {e}", b.at));
                continue;
            }
        };
        let result = match m {
            Marker::NotRun(reason) => {
                skipped += 1;
                check_reason(&reason, &b.text, &readme)
                    .map_err(|e| format!("its marker's reason '{reason}' is not so: {e}"))
            }
            Marker::Expect(texts) => {
                ran += 1;
                run_block(b, &texts, &session)
            }
            Marker::None => {
                ran += 1;
                run_block(b, &[], &session)
            }
        };
        if let Err(e) = result {
            problems.push(format!("{}: {e}", b.at));
        }
    }
    eprintln!(
        "{} blocks: {ran} run, {skipped} not run (with their reasons)",
        blocks.len()
    );
    assert!(
        problems.is_empty(),
        "{} of {} blocks fail (run as written, or mark the block `{NOT_RUN} REASON -->`):\n\n{}",
        problems.len(),
        blocks.len(),
        problems.join("\n\n")
    );
}
