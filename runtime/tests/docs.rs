//! The documentation's commands and walkthrough stay true. Every `softplc` command line in a
//! code block of README.md and docs/*.md is one the binary accepts (its subcommand, flags and
//! fixed values spelled as the binary spells them); the first project the README walks
//! through is the one in `examples/first-project/`, passes `check` and its scenario, and its
//! mistakes read as the README shows them.

use std::path::PathBuf;
use std::process::Command;

use crate::common::host::{repo, scratch_dir, softplc_in as softplc};

const BIN: &str = env!("CARGO_BIN_EXE_softplc");

/// The documents an engineer reads.
fn documents() -> Vec<PathBuf> {
    let mut docs = vec![repo().join("README.md")];
    let mut more: Vec<PathBuf> = std::fs::read_dir(repo().join("docs"))
        .expect("docs/")
        .map(|e| e.expect("an entry").path())
        .filter(|p| p.extension().is_some_and(|e| e == "md"))
        .collect();
    more.sort();
    docs.extend(more);
    docs
}

/// The code blocks of a Markdown text: (the line after the opening fence, the fence's info
/// string, the block's lines).
fn code_blocks(text: &str) -> Vec<(usize, String, Vec<String>)> {
    let mut blocks = Vec::new();
    let mut open: Option<(usize, String, Vec<String>)> = None;
    for (n, line) in text.lines().enumerate() {
        let fence = line.trim_start().strip_prefix("```");
        match (&mut open, fence) {
            (None, Some(info)) => open = Some((n + 2, info.trim().to_string(), Vec::new())),
            (Some(_), Some(_)) => blocks.extend(open.take()),
            (Some((_, _, lines)), None) => lines.push(line.to_string()),
            (None, None) => {}
        }
    }
    blocks
}

/// The arguments of a documented `softplc` command line, as a shell would pass them, with the
/// documentation's notation taken out: `[--for 10s]` is an option shown (it is kept), `a|b`
/// a choice (the first is taken); `None` for a line that is not a `softplc` command.
fn softplc_args(line: &str) -> Option<Vec<String>> {
    let mut line = line.trim().trim_start_matches("$ ").trim_start();
    // A comment, a pipe or a second command ends it.
    for end in [" #", " | ", " && ", "; ", " > "] {
        if let Some(i) = line.find(end) {
            line = &line[..i];
        }
    }
    let mut words = split_words(line);
    // `sudo`, environment assignments and `cargo run ... --` come before the command.
    while let Some(first) = words.first() {
        let assignment = first
            .split_once('=')
            .is_some_and(|(name, _)| name.chars().all(|c| c.is_ascii_uppercase() || c == '_'));
        if first == "sudo" || assignment {
            words.remove(0);
        } else {
            break;
        }
    }
    if words.first().is_some_and(|w| w == "cargo") {
        let dashes = words.iter().position(|w| w == "--")?;
        if !words[..dashes].iter().any(|w| w == "softplc") {
            return None;
        }
        words.drain(..=dashes);
        words.insert(0, "softplc".into());
    }
    if words.first().map(String::as_str) != Some("softplc") || words.len() < 2 {
        return None;
    }
    if words.iter().any(|w| w.contains("...") || w.contains('…')) {
        return None;
    }
    Some(
        words[1..]
            .iter()
            .map(|w| {
                let w = w.trim_matches(|c| c == '[' || c == ']');
                // `input|output|setting` is a choice; `--only input|output` keeps the first.
                w.split('|').next().unwrap_or(w).to_string()
            })
            .filter(|w| !w.is_empty())
            .collect(),
    )
}

/// The lines of a block as a shell reads them: a line ending in `\` goes on in the next. Each
/// with the index of its first line.
fn logical_lines(lines: &[String]) -> Vec<(usize, String)> {
    let mut out: Vec<(usize, String)> = Vec::new();
    let mut open = false;
    for (i, line) in lines.iter().enumerate() {
        let (text, goes_on) = match line.trim_end().strip_suffix('\\') {
            Some(t) => (t, true),
            None => (line.as_str(), false),
        };
        match out.last_mut() {
            Some((_, last)) if open => {
                last.push(' ');
                last.push_str(text.trim());
            }
            _ => out.push((i, text.to_string())),
        }
        open = goes_on;
    }
    out
}

/// Words as a shell splits them (single and double quotes group).
fn split_words(line: &str) -> Vec<String> {
    let mut words = Vec::new();
    let mut word = String::new();
    let mut quote = None;
    let mut in_word = false;
    for c in line.chars() {
        match (quote, c) {
            (Some(q), c) if c == q => quote = None,
            (Some(_), c) => word.push(c),
            (None, '"' | '\'') => {
                quote = Some(c);
                in_word = true;
            }
            (None, c) if c.is_whitespace() => {
                if in_word {
                    words.push(std::mem::take(&mut word));
                    in_word = false;
                }
            }
            (None, c) => {
                word.push(c);
                in_word = true;
            }
        }
    }
    if in_word {
        words.push(word);
    }
    words
}

#[test]
fn the_notation_of_documented_commands_is_read_as_a_shell_would() {
    assert_eq!(
        softplc_args("softplc run PROJECT [--for 10s]  # until SIGINT"),
        Some(vec![
            "run".into(),
            "PROJECT".into(),
            "--for".into(),
            "10s".into()
        ])
    );
    assert_eq!(
        softplc_args("softplc points minimod [--only input|output|setting]"),
        Some(vec![
            "points".into(),
            "minimod".into(),
            "--only".into(),
            "input".into()
        ])
    );
    assert_eq!(
        softplc_args("cargo run --release -p softplc -- check p.yaml | head"),
        Some(vec!["check".into(), "p.yaml".into()])
    );
    assert_eq!(
        softplc_args("SOFTPLC_LOG=debug sudo softplc sim --pty 'minimod@5'"),
        Some(vec!["sim".into(), "--pty".into(), "minimod@5".into()])
    );
    assert_eq!(softplc_args("cargo test -p softplc"), None);
    assert_eq!(softplc_args("journalctl -u softplc@press -f"), None);
}

#[test]
fn every_documented_softplc_command_is_accepted_by_the_binary() {
    let mut checked = 0;
    let mut wrong = Vec::new();
    for doc in documents() {
        let text = std::fs::read_to_string(&doc).expect("a document");
        let name = doc
            .strip_prefix(repo())
            .unwrap_or(&doc)
            .display()
            .to_string();
        for (first, info, lines) in code_blocks(&text) {
            // Configuration, programs and output are not commands.
            if !matches!(info.as_str(), "" | "sh" | "bash" | "console" | "shell") {
                continue;
            }
            for (i, line) in logical_lines(&lines) {
                let Some(args) = softplc_args(&line) else {
                    continue;
                };
                // `--help` after the command: the binary parses every argument before it (an
                // unknown subcommand or flag, or a value outside a fixed set, fails) and then
                // prints the help instead of running.
                let out = Command::new(BIN)
                    .args(&args)
                    .arg("--help")
                    .output()
                    .expect("softplc runs");
                checked += 1;
                if !out.status.success() {
                    wrong.push(format!(
                        "{name}:{}: softplc {}: {}",
                        first + i,
                        args.join(" "),
                        String::from_utf8_lossy(&out.stderr)
                            .lines()
                            .next()
                            .unwrap_or("")
                    ));
                }
            }
        }
    }
    assert!(wrong.is_empty(), "{}", wrong.join("\n"));
    // README and docs show dozens; far fewer means the reader of code blocks broke.
    assert!(checked >= 30, "only {checked} commands found");
}

/// The README's code block that begins with `first_line`.
fn readme_block(first_line: &str) -> String {
    let readme = std::fs::read_to_string(repo().join("README.md")).expect("README");
    code_blocks(&readme)
        .into_iter()
        .map(|(_, _, lines)| lines)
        .find(|lines| lines.first().is_some_and(|l| l == first_line))
        .map(|lines| lines.join("\n") + "\n")
        .unwrap_or_else(|| panic!("README has no block beginning {first_line:?}"))
}

fn first_project(file: &str) -> String {
    std::fs::read_to_string(repo().join("examples/first-project").join(file)).expect(file)
}

#[test]
fn the_readme_walkthrough_is_the_first_project_and_it_passes() {
    for file in ["project.yaml", "fan.expr", "fan.scenario.yaml"] {
        let text = first_project(file);
        let first = text.lines().next().expect("a first line");
        assert_eq!(
            readme_block(first),
            text,
            "README's copy of examples/first-project/{file}"
        );
    }
    let project = repo().join("examples/first-project/project.yaml");
    let check = softplc(&repo(), &["check", project.to_str().expect("a path")]);
    assert!(check.0, "{}", check.1);
    assert!(!check.1.contains("warning"), "{}", check.1);
    let test = softplc(&repo(), &["test", project.to_str().expect("a path")]);
    assert!(test.0, "{}", test.1);
    assert!(test.1.contains("1 passed, 0 failed"), "{}", test.1);
}

#[test]
fn the_readme_mistakes_read_as_check_prints_them() {
    let dir = scratch_dir("docs", "mistakes");
    for file in ["project.yaml", "fan.expr"] {
        let mut text = first_project(file);
        if file == "project.yaml" {
            text = text.replace("point: mm1.X3 }", "point: mm1.x3 }").replace(
                "{ name: alarm,     point: mm1.Y2,",
                "{ name: alarm,     point: mm1.Y1,",
            );
        }
        std::fs::write(dir.join(file), text).expect("a scratch file");
    }
    let (ok, out) = softplc(&dir, &["check", "project.yaml"]);
    assert!(!ok);
    let shown = readme_block(
        "project.yaml:20:31: error: module mm1 (minimod) has no point \"x3\"; did you mean X3?",
    );
    for line in shown.lines() {
        assert!(
            out.contains(line),
            "README shows {line:?}; check printed:\n{out}"
        );
    }
    // Best effort: the test's scratch folder (it may not exist).
    drop(std::fs::remove_dir_all(&dir));
}
