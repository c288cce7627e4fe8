//! The guide against the program: every `acq` command line in README.md
//! and docs/src names only options its command has (`acq CMD --help`), and
//! a usage line (one that shows an option in brackets) names all of them,
//! or ends in `[...]` to say that it does not. And the outputs the guide
//! quotes from a command are that command's output today: a block after
//! `<!-- output of: acq ARGS -->` is run and each of its lines found in
//! what acq prints, a number equal at the digits the guide shows. So a
//! renamed option, a new one or a changed figure fails here, not in a
//! reader's terminal.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

use crate::common::{acq, root, stderr, stdout};

/// The guide's pages: README.md, ARCHITECTURE.md and every chapter.
fn pages() -> Vec<PathBuf> {
    crate::common::pages::project_pages(root())
}

/// A fenced block: its info string, its first line's number and its lines,
/// and the `<!-- output of: ... -->` comment right before it, if any.
struct Block {
    info: String,
    line: usize,
    lines: Vec<String>,
    output_of: Option<String>,
}

fn blocks(text: &str) -> Vec<Block> {
    let mut blocks = Vec::new();
    let mut open: Option<Block> = None;
    let mut last_prose = "";
    for (index, line) in text.lines().enumerate() {
        let fence = line.trim_start().starts_with("```");
        match (&mut open, fence) {
            (None, true) => {
                let output_of = last_prose
                    .trim()
                    .strip_prefix("<!-- output of: ")
                    .and_then(|rest| rest.strip_suffix("-->"))
                    .map(|command| command.trim().to_string());
                open = Some(Block {
                    info: line.trim_start()[3..].trim().to_string(),
                    line: index + 2,
                    lines: Vec::new(),
                    output_of,
                });
            }
            (Some(_), true) => blocks.push(open.take().unwrap()),
            (Some(block), false) => block.lines.push(line.to_string()),
            (None, false) => {
                if !line.trim().is_empty() {
                    last_prose = line;
                }
            }
        }
    }
    blocks
}

/// The `acq` command lines of a block, continuation lines joined (a
/// trailing `\`, or an indented line that goes on with options).
fn command_lines(block: &Block) -> Vec<(usize, String)> {
    let mut commands: Vec<(usize, String)> = Vec::new();
    for (offset, line) in block.lines.iter().enumerate() {
        let trimmed = line.trim();
        let trimmed = trimmed.strip_prefix("$ ").unwrap_or(trimmed);
        let continues = commands.last().is_some_and(|(_, c)| {
            c.ends_with('\\') || (line.starts_with("  ") && trimmed.starts_with(['[', '-']))
        });
        if continues {
            let (_, command) = commands.last_mut().unwrap();
            *command = format!("{} {trimmed}", command.trim_end_matches('\\').trim_end());
        } else if trimmed.starts_with("acq ") {
            commands.push((block.line + offset, trimmed.to_string()));
        }
    }
    commands
}

/// The options of `acq PATH --help`, one set per option (its short and
/// long forms), and whether the command has subcommands of its own.
fn help_of(path: &[&str]) -> Option<(Vec<BTreeSet<String>>, bool)> {
    let mut args = path.to_vec();
    args.push("--help");
    let output = acq(&args);
    if !output.status.success() {
        return None;
    }
    let text = stdout(&output);
    let options = text
        .lines()
        .map(str::trim_start)
        .filter(|line| line.starts_with('-'))
        .map(|line| {
            line.split([' ', ','])
                .take(3)
                .filter(|word| word.starts_with('-') && word.len() > 1)
                .map(|word| word.split('=').next().unwrap().to_string())
                .collect()
        })
        .collect();
    Some((options, text.contains("\nCommands:")))
}

/// The options a command line names: `--long` and `-x` words, in or out
/// of brackets and alternatives.
fn options_named(command: &str) -> BTreeSet<String> {
    command
        .split(|c: char| c.is_whitespace() || "[]|()".contains(c))
        .filter(|word| word.starts_with('-') && word.len() > 1 && word != &"-")
        .filter(|word| {
            word.chars()
                .nth(1)
                .is_some_and(|c| c.is_ascii_alphabetic() || c == '-')
        })
        .map(|word| word.split(['=', ',', ')', '`']).next().unwrap().to_string())
        .filter(|word| word.len() > 1 && word != "--")
        .collect()
}

#[test]
fn every_command_line_of_the_guide_names_the_options_acq_has() {
    type Help = Option<(Vec<BTreeSet<String>>, bool)>;
    let mut helps: BTreeMap<Vec<String>, Help> = BTreeMap::new();
    let mut wrong = Vec::new();
    let mut checked = 0;
    for page in pages() {
        let text = std::fs::read_to_string(&page).unwrap();
        let name = page.strip_prefix(root()).unwrap().display().to_string();
        for block in blocks(&text) {
            if !matches!(block.info.as_str(), "" | "sh" | "console" | "text") {
                continue;
            }
            // Per command, the options its usage lines in this block name.
            let mut usage: BTreeMap<Vec<String>, (usize, BTreeSet<String>, bool)> = BTreeMap::new();
            for (line, command) in command_lines(&block) {
                let words: Vec<&str> = command.split_whitespace().collect();
                let mut path = vec![words[1].to_string()];
                let help = helps
                    .entry(path.clone())
                    .or_insert_with(|| help_of(&[words[1]]))
                    .clone();
                let Some((mut options, has_commands)) = help else {
                    wrong.push(format!("{name}:{line}: `acq {}` is no command", words[1]));
                    continue;
                };
                if has_commands {
                    let Some(sub) = words.get(2).filter(|w| !w.starts_with('-')) else {
                        continue;
                    };
                    path.push(sub.to_string());
                    let refs: Vec<&str> = path.iter().map(String::as_str).collect();
                    match helps
                        .entry(path.clone())
                        .or_insert_with(|| help_of(&refs))
                        .clone()
                    {
                        Some((sub_options, _)) => options = sub_options,
                        None => {
                            wrong.push(format!(
                                "{name}:{line}: `acq {}` is no command",
                                refs.join(" ")
                            ));
                            continue;
                        }
                    }
                }
                checked += 1;
                let named = options_named(&command);
                let known: BTreeSet<String> = options.iter().flatten().cloned().collect();
                for option in named.difference(&known) {
                    wrong.push(format!(
                        "{name}:{line}: `acq {}` has no option {option}",
                        path.join(" ")
                    ));
                }
                if command.contains("[-") {
                    let entry = usage
                        .entry(path.clone())
                        .or_insert((line, BTreeSet::new(), false));
                    entry.1.extend(named);
                    entry.2 |= command.contains("[...]");
                }
            }
            for (path, (line, named, more)) in usage {
                if more {
                    continue;
                }
                let (options, _) = helps[&path].clone().unwrap();
                // An option is named by either of its forms.
                let missing: Vec<&String> = options
                    .iter()
                    .filter(|forms| !forms.iter().any(|f| matches!(f.as_str(), "-h" | "-V")))
                    .filter(|forms| forms.is_disjoint(&named))
                    .filter_map(|forms| forms.last())
                    .collect();
                if !missing.is_empty() {
                    wrong.push(format!(
                        "{name}:{line}: the usage of `acq {}` leaves out {missing:?} (name them, or end the line in [...])",
                        path.join(" ")
                    ));
                }
            }
        }
    }
    assert!(
        checked > 40,
        "only {checked} command lines found in the guide"
    );
    assert!(wrong.is_empty(), "{}", wrong.join("\n"));
}

/// A guide's token against acq's: equal as text, or as numbers at the
/// digits the guide shows (`193.447` stands for 193.4471...).
fn token_matches(guide: &str, acq: &str) -> bool {
    if guide == acq || guide == "..." {
        return true;
    }
    let (Ok(shown), Ok(value)) = (guide.parse::<f64>(), acq.parse::<f64>()) else {
        return false;
    };
    let decimals = guide
        .split_once('.')
        .map_or(0, |(_, fraction)| fraction.len() as i32);
    let step = 10f64.powi(-decimals);
    (value - shown).abs() <= 0.5 * step * (1.0 + 1e-9)
}

fn tokens(line: &str) -> Vec<&str> {
    line.split(|c: char| ",=;".contains(c) || c.is_whitespace())
        .filter(|t| !t.is_empty())
        .collect()
}

/// Where `guide`'s line is among acq's: each token matched in order.
fn line_matches(guide: &str, acq: &str) -> bool {
    let (g, a) = (tokens(guide), tokens(acq));
    g.len() == a.len() && g.iter().zip(&a).all(|(g, a)| token_matches(g, a))
}

#[test]
fn the_outputs_the_guide_quotes_are_what_acq_prints() {
    let mut quoted = 0;
    let mut wrong = Vec::new();
    for page in pages() {
        let text = std::fs::read_to_string(&page).unwrap();
        let name = page.strip_prefix(root()).unwrap().display().to_string();
        for block in blocks(&text) {
            let Some(command) = &block.output_of else {
                continue;
            };
            quoted += 1;
            let dir = tempfile::tempdir().unwrap();
            let args: Vec<String> = command
                .split_whitespace()
                .skip(1)
                .map(|word| word.replace("{dir}", dir.path().to_str().unwrap()))
                .collect();
            let (args, file) = match args.iter().position(|a| a == ";") {
                Some(at) => (args[..at].to_vec(), args.get(at + 1).cloned()),
                None => (args, None),
            };
            let refs: Vec<&str> = args.iter().map(String::as_str).collect();
            let output = acq(&refs);
            assert!(
                output.status.success(),
                "{name}:{}: {command}: {}",
                block.line,
                stderr(&output)
            );
            let printed = match &file {
                Some(file) => std::fs::read_to_string(Path::new(file)).unwrap(),
                None => format!("{}{}", stdout(&output), stderr(&output)),
            };
            let printed: Vec<&str> = printed.lines().collect();
            for (offset, line) in block.lines.iter().enumerate() {
                if line.trim().is_empty() {
                    continue;
                }
                if !printed.iter().any(|p| line_matches(line, p)) {
                    wrong.push(format!(
                        "{name}:{}: `{line}` is not in what `{command}` prints",
                        block.line + offset
                    ));
                }
            }
        }
    }
    assert!(quoted >= 2, "only {quoted} quoted outputs in the guide");
    assert!(wrong.is_empty(), "{}", wrong.join("\n"));
}

#[test]
fn a_figure_at_other_digits_or_another_value_does_not_match() {
    assert!(token_matches("193.447", "193.44712"));
    assert!(token_matches("1.7321", "1.73205"));
    assert!(!token_matches("1.1548", "1.73205"));
    assert!(!token_matches("193.45", "193.44"));
    assert!(token_matches("...", "anything"));
    assert!(line_matches(
        "hold1,3.99,10.39,sg03,MPa",
        "hold1,3.9902,10.3948,sg03,MPa"
    ));
    assert!(!line_matches("hold1,3.99", "hold1,3.99,10.39"));
}
