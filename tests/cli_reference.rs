//! The command-line reference, `docs/cli.md`, against the binary: every option that
//! `render --help`, `render merge --help` and `render denoise --help` print is in the page's
//! section for that command, and every option a section names is one the command has.
//!
//! The page marks each reference section with HTML comments:
//!
//! ```text
//! <!-- options: render -->          ... <!-- end -->
//! <!-- options: render merge -->    ... <!-- end -->
//! <!-- options: render denoise -->  ... <!-- end -->
//! <!-- options: render hidden -->   ... <!-- end -->
//! ```
//!
//! The markers stand on lines of their own. Inside a section every `--word` token counts as an option of that command, so prose that
//! mentions another command's options belongs outside the markers. The `hidden` section holds
//! the measurement switches that `--help` does not show: each must be accepted by `render`
//! and absent from its help. `--help` and `--version` are left out of the comparison.

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;
use std::process::Command;

const PAGE: &str = "docs/cli.md";

/// Options every command has and the reference need not list.
const EXCLUDED: [&str; 2] = ["--help", "--version"];

/// The commands whose `--help` the reference must match, as their section names.
const COMMANDS: [&str; 3] = ["render", "render merge", "render denoise"];

/// The section of options that exist but that `render --help` does not show.
const HIDDEN: &str = "render hidden";

fn run_render(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_render"))
        .args(args)
        .output()
        .unwrap_or_else(|e| panic!("cannot run render {args:?}: {e}"))
}

/// `render [SUBCOMMAND] --help`.
fn help_of(command: &str) -> String {
    let mut args: Vec<&str> = command.split_whitespace().skip(1).collect();
    args.push("--help");
    let out = run_render(&args);
    assert!(
        out.status.success(),
        "render {args:?} failed:\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).expect("help is UTF-8")
}

/// One long option of a help text: its name with `--`, and its short form if it has one.
#[derive(Debug, PartialEq)]
struct HelpOption {
    long: String,
    short: Option<char>,
}

fn is_name_char(c: char) -> bool {
    c.is_ascii_lowercase() || c.is_ascii_digit() || c == '-'
}

/// Reads `--name` at the start of `s`; returns the name with its dashes, if `s` starts with
/// one and the name ends where a name must (end of line, a space, `<`, `=`, `[` or `,`).
fn leading_long(s: &str) -> Option<String> {
    let rest = s.strip_prefix("--")?;
    if !rest.starts_with(|c: char| c.is_ascii_lowercase()) {
        return None;
    }
    let end = rest.find(|c: char| !is_name_char(c)).unwrap_or(rest.len());
    let after = rest[end..].chars().next();
    match after {
        None | Some(' ' | '<' | '=' | '[' | ',') => Some(format!("--{}", &rest[..end])),
        _ => None,
    }
}

/// The options of a clap help text: the lines that start with whitespace and then
/// `-x, --name` or `--name`. Option lines are indented by a few spaces, their descriptions
/// further, so a description that happens to begin with an option's name is not read as one.
fn help_options(help: &str) -> Vec<HelpOption> {
    let mut options = Vec::new();
    for line in help.lines() {
        let body = line.trim_start();
        let indent = line.len() - body.len();
        if indent == 0 || indent > 8 {
            continue;
        }
        let (short, rest) = match body.as_bytes() {
            [b'-', c, b',', b' ', ..] if c.is_ascii_alphabetic() => (Some(*c as char), &body[4..]),
            _ => (None, body),
        };
        if let Some(long) = leading_long(rest) {
            options.push(HelpOption { long, short });
        }
    }
    options
}

/// Every `--name` token of a text (not part of a longer run of dashes or of a word).
fn long_tokens(text: &str) -> BTreeSet<String> {
    let chars: Vec<char> = text.chars().collect();
    let mut tokens = BTreeSet::new();
    let mut i = 0;
    while i + 2 < chars.len() {
        let starts = chars[i] == '-'
            && chars[i + 1] == '-'
            && chars[i + 2].is_ascii_lowercase()
            && (i == 0 || !(chars[i - 1] == '-' || chars[i - 1].is_alphanumeric()));
        if starts {
            let mut j = i + 2;
            while j < chars.len() && is_name_char(chars[j]) {
                j += 1;
            }
            let name: String = chars[i..j].iter().collect();
            tokens.insert(name.trim_end_matches('-').to_string());
            i = j;
        } else {
            i += 1;
        }
    }
    tokens
}

/// Whether a text writes the short option `-x` as a token of its own.
fn has_short(text: &str, short: char) -> bool {
    let needle = format!("-{short}");
    text.match_indices(&needle).any(|(at, _)| {
        let before = text[..at].chars().next_back();
        let after = text[at + needle.len()..].chars().next();
        !matches!(before, Some(c) if c == '-' || c.is_alphanumeric())
            && !matches!(after, Some(c) if c == '-' || c.is_alphanumeric())
    })
}

/// The page's reference sections by command: the lines between a line
/// `<!-- options: COMMAND -->` and the next line `<!-- end -->` (markers stand on lines of
/// their own, so prose may quote them). A section named twice, nested or left open is an
/// error.
fn sections(page: &str) -> Result<BTreeMap<String, String>, String> {
    let mut found = BTreeMap::new();
    let mut open: Option<(String, String)> = None;
    for line in page.lines() {
        let marker = line.trim();
        let name = marker
            .strip_prefix("<!-- options:")
            .and_then(|rest| rest.strip_suffix("-->"))
            .map(|name| name.trim().to_string());
        match (name, &mut open) {
            (Some(name), Some((current, _))) => {
                return Err(format!("section `{name}` opens inside section `{current}`"));
            }
            (Some(name), None) => open = Some((name, String::new())),
            (None, Some(_)) if marker == "<!-- end -->" => {
                let (name, body) = open.take().expect("a section is open");
                if found.insert(name.clone(), body).is_some() {
                    return Err(format!("section `{name}` appears twice"));
                }
            }
            (None, Some((_, body))) => {
                body.push_str(line);
                body.push('\n');
            }
            (None, None) => {}
        }
    }
    match open {
        Some((name, _)) => Err(format!("section `{name}` has no `<!-- end -->` line")),
        None => Ok(found),
    }
}

/// The differences between one command's help and its section, one line each.
fn compare(command: &str, help: &[HelpOption], section: &str) -> Vec<String> {
    let excluded: BTreeSet<&str> = EXCLUDED.into_iter().collect();
    let in_help: BTreeSet<&str> = help
        .iter()
        .map(|o| o.long.as_str())
        .filter(|o| !excluded.contains(o))
        .collect();
    let in_page = long_tokens(section);
    let mut problems = Vec::new();
    for option in &in_help {
        if !in_page.contains(*option) {
            problems.push(format!(
                "`{command}`: {option} is in --help but missing from {PAGE}"
            ));
        }
    }
    for option in &in_page {
        if !in_help.contains(option.as_str()) && !excluded.contains(option.as_str()) {
            problems.push(format!(
                "`{command}`: {PAGE} names {option}, which `{command} --help` does not list"
            ));
        }
    }
    for option in help {
        if let Some(short) = option.short {
            if !excluded.contains(option.long.as_str()) && !has_short(section, short) {
                problems.push(format!(
                    "`{command}`: the short form -{short} of {} is not noted in {PAGE}",
                    option.long
                ));
            }
        }
    }
    problems
}

/// Whether `render` accepts `option` as an argument (it may then stop for a missing scene or
/// value, but not for an unknown argument).
fn render_accepts(option: &str) -> bool {
    let out = run_render(&[option]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    !stderr.contains("unexpected argument")
}

fn page() -> String {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join(PAGE);
    std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

fn report(problems: &[String]) {
    assert!(
        problems.is_empty(),
        "{PAGE} and the command line disagree ({} problems):\n  {}",
        problems.len(),
        problems.join("\n  ")
    );
}

#[test]
fn cli_reference_lists_every_option_of_every_command() {
    let page = page();
    let sections = sections(&page).unwrap_or_else(|e| panic!("{PAGE}: {e}"));
    let mut problems = Vec::new();
    for command in COMMANDS {
        let help = help_of(command);
        let options = help_options(&help);
        assert!(
            options.iter().any(|o| o.long == "--help"),
            "no options read from `{command} --help` (has its format changed?):\n{help}"
        );
        match sections.get(command) {
            Some(section) => problems.extend(compare(command, &options, section)),
            None => problems.push(format!(
                "`{command}`: {PAGE} has no `<!-- options: {command} -->` section"
            )),
        }
    }
    for name in sections.keys() {
        if !COMMANDS.contains(&name.as_str()) && name != HIDDEN {
            problems.push(format!(
                "{PAGE} has a section `{name}` that names no command"
            ));
        }
    }
    report(&problems);
}

#[test]
fn cli_reference_hidden_options_exist_and_stay_hidden() {
    let page = page();
    let sections = sections(&page).unwrap_or_else(|e| panic!("{PAGE}: {e}"));
    let Some(section) = sections.get(HIDDEN) else {
        panic!("{PAGE} has no `<!-- options: {HIDDEN} -->` section");
    };
    let shown: BTreeSet<String> = help_options(&help_of("render"))
        .into_iter()
        .map(|o| o.long)
        .collect();
    let mut problems = Vec::new();
    let hidden = long_tokens(section);
    assert!(
        !hidden.is_empty(),
        "{PAGE}: section `{HIDDEN}` names no option"
    );
    for option in &hidden {
        if shown.contains(option) {
            problems.push(format!(
                "`{HIDDEN}`: {option} is shown by `render --help`; list it under `render`"
            ));
        } else if !render_accepts(option) {
            problems.push(format!(
                "`{HIDDEN}`: {PAGE} names {option}, which `render` does not accept"
            ));
        }
    }
    report(&problems);
}

// ---------------------------------------------------------------------------------------
// The parsers themselves, on made-up text, so that a comparison that passes is not one that
// read nothing.

#[test]
fn help_options_reads_long_and_short_forms_only_from_option_lines() {
    let help = "\
Usage: render [OPTIONS] <SCENE>

Options:
  -o, --output <FILE.exr>
          Output EXR file

      --no-png
          Do not write the PNG preview; see --view
      --spp=<N>
--not-indented
          --described-deeper is prose
  -h, --help
";
    let options = help_options(help);
    let longs: Vec<&str> = options.iter().map(|o| o.long.as_str()).collect();
    assert_eq!(longs, ["--output", "--no-png", "--spp", "--help"]);
    assert_eq!(options[0].short, Some('o'));
    assert_eq!(options[1].short, None);
    assert_eq!(options[3].short, Some('h'));
}

#[test]
fn sections_and_tokens_report_missing_and_extra_options() {
    let page = "\
Prose may name --other-tools' flags.
<!-- options: render -->
| `-o, --output FILE` | out |
| `--spp N` | with --target-error, ... |
| `--gone` | |
<!-- end -->
";
    let found = sections(page).unwrap();
    assert_eq!(found.len(), 1);
    let opt = |long: &str, short: Option<char>| HelpOption {
        long: long.to_string(),
        short,
    };
    let help = [
        opt("--output", Some('o')),
        opt("--spp", None),
        opt("--target-error", None),
        opt("--seed", None),
        opt("--help", Some('h')),
    ];
    let problems = compare("render", &help, &found["render"]);
    assert_eq!(problems.len(), 2, "{problems:#?}");
    assert!(problems[0].contains("--seed is in --help but missing"));
    assert!(problems[1].contains("names --gone"));

    let no_short =
        "<!-- options: render -->\n`--output`, `--spp`, `--target-error`, `--seed`\n<!-- end -->";
    let problems = compare("render", &help, &sections(no_short).unwrap()["render"]);
    assert_eq!(problems.len(), 1, "{problems:#?}");
    assert!(problems[0].contains("short form -o"));

    assert!(sections("<!-- options: render -->\n`--spp`").is_err());
    assert!(sections("<!-- options: a -->\n<!-- options: b -->\n<!-- end -->").is_err());
    assert!(
        sections("prose quotes `<!-- options: a -->` and `<!-- end -->`")
            .unwrap()
            .is_empty()
    );
    assert!(
        sections("<!-- options: a -->\n<!-- end -->\n<!-- options: a -->\n<!-- end -->").is_err()
    );
    assert_eq!(
        long_tokens("|---|---| a--b `--x-y`, --z. ---w"),
        BTreeSet::from(["--x-y".to_string(), "--z".to_string()])
    );
}
