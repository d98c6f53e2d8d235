//! The defaults the user documentation states are the command line's own (issue 39): every
//! row of docs/training.md's "Defaults, and why" table, every `(default N)` of an option in
//! docs/meshing.md, docs/tps-import.md and docs/clinical.md, and the README's ω₀ and demo step
//! count, read from the documents and compared with the defaults of the command's definition
//! (clap's default value, else the `default` its help text states). A changed default fails
//! here until the sentence that states it is changed too.

use clap::CommandFactory;
use std::path::PathBuf;

fn doc(name: &str) -> String {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("the workspace")
        .join(name);
    std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// The numbers at the start of `text` (after spaces): a comma-separated list without spaces
/// (`256,256,256,256`) or one number, `10⁻³` included; empty where it starts with none.
fn leading_numbers(text: &str) -> Vec<f64> {
    let word: String = text
        .trim_start()
        .chars()
        .take_while(|c| !c.is_whitespace() && !";)]".contains(*c))
        .collect();
    let word = word.trim_end_matches([',', '.']);
    if let Some(exp) = word.strip_prefix("10") {
        if let Some(sup) = exp.strip_prefix('⁻') {
            let digits: String = sup
                .chars()
                .map(|c| match "⁰¹²³⁴⁵⁶⁷⁸⁹".chars().position(|s| s == c) {
                    Some(d) => char::from(b'0' + d as u8),
                    None => c,
                })
                .collect();
            if let Ok(e) = digits.parse::<i32>() {
                return vec![10f64.powi(-e)];
            }
        }
    }
    word.split(',')
        .map(|n| n.parse::<f64>())
        .collect::<Result<Vec<_>, _>>()
        .unwrap_or_default()
}

/// The first number after the word "default" in `text` (any case; `default 128`,
/// `default: 3000`, `[default: 0.1]`, `default: the … at 21 times`).
fn stated_default(text: &str) -> Option<Vec<f64>> {
    // clap's own "[default: X]" where the help shows one (the training options' table puts
    // it there), else the first "default" of the prose.
    let rest = match text.find("[default:") {
        Some(at) => &text[at + "[default:".len()..],
        None => {
            let at = text.to_lowercase().find("default")?;
            &text[at + "default".len()..]
        }
    };
    let start = rest.find(|c: char| c.is_ascii_digit())?;
    let numbers = leading_numbers(&rest[start..]);
    (!numbers.is_empty()).then_some(numbers)
}

/// The default of `--long` of subcommand `command`: clap's default value, else what its help
/// text states.
fn default_of(command: &str, long: &str) -> Vec<f64> {
    let cli = dynaslice_cli::Cli::command();
    let sub = cli
        .find_subcommand(command)
        .unwrap_or_else(|| panic!("no subcommand {command}"));
    let arg = sub
        .get_arguments()
        .find(|a| a.get_long() == Some(long))
        .unwrap_or_else(|| panic!("dynaslice {command} has no --{long}"));
    let values: Vec<String> = arg
        .get_default_values()
        .iter()
        .map(|v| v.to_string_lossy().into_owned())
        .collect();
    if !values.is_empty() {
        return leading_numbers(&values.join(","));
    }
    let help = arg
        .get_long_help()
        .or(arg.get_help())
        .map(|h| h.to_string())
        .unwrap_or_default();
    stated_default(&help)
        .unwrap_or_else(|| panic!("dynaslice {command} --{long} states no default: {help}"))
}

fn assert_same(what: &str, documented: &[f64], code: &[f64]) {
    let same = documented.len() == code.len()
        && documented
            .iter()
            .zip(code)
            .all(|(a, b)| (a - b).abs() <= 1e-9 * b.abs().max(1.0));
    assert!(
        same,
        "{what}: the docs say {documented:?}, the command's default is {code:?}"
    );
}

/// The options (`--name`) named in a table cell.
fn options_in(cell: &str) -> Vec<String> {
    cell.split('`')
        .filter_map(|s| s.strip_prefix("--"))
        .map(|s| s.split_whitespace().next().unwrap_or(s).to_string())
        .collect()
}

#[test]
fn the_training_defaults_table_is_the_commands() {
    let text = doc("docs/training.md");
    let table = text
        .split("## Defaults, and why")
        .nth(1)
        .expect("docs/training.md has its defaults table");
    let mut checked = 0;
    for row in table.lines().take_while(|l| !l.starts_with("## ")) {
        let cells: Vec<&str> = row.split('|').map(str::trim).collect();
        // | option(s) | default(s) | why |
        if cells.len() < 4 || !cells[1].starts_with("`--") {
            continue;
        }
        let options = options_in(cells[1]);
        // One value per option, in order ("1024 per class, 1024 per class, 1024"); a single
        // option takes the whole cell ("256,256,256,256", "10⁻³, cosine to 10⁻⁴").
        let values: Vec<&str> = if options.len() == 1 {
            vec![cells[2]]
        } else {
            cells[2].split(", ").collect()
        };
        assert_eq!(
            values.len(),
            options.len(),
            "docs/training.md row {row:?}: one default per option"
        );
        for (option, value) in options.iter().zip(values) {
            let documented = leading_numbers(value);
            if documented.is_empty() {
                // "none", "all cores": no number to compare.
                continue;
            }
            let code = default_of("train", option);
            assert_same(
                &format!("docs/training.md, train --{option}"),
                &documented,
                &code,
            );
            checked += 1;
        }
    }
    assert!(checked >= 15, "only {checked} defaults found in the table");
}

#[test]
fn the_option_defaults_in_the_other_docs_are_the_commands() {
    // (document, command): every line naming an option of the command and a default.
    let cases = [
        (
            "docs/meshing.md",
            "mesh",
            &["resolution", "safety", "newton-steps"][..],
        ),
        ("docs/tps-import.md", "rtstruct", &["tolerance"][..]),
        ("docs/clinical.md", "measure", &["itv-spacing", "times"][..]),
    ];
    for (name, command, options) in cases {
        let text = doc(name);
        for option in options {
            let needle = format!("`--{option}");
            let line = text
                .lines()
                .find(|l| {
                    l.contains(&needle)
                        && l.split(&needle).nth(1).is_some_and(|rest| {
                            rest.to_lowercase().contains("default")
                                && stated_default(rest).is_some()
                        })
                })
                .unwrap_or_else(|| panic!("{name}: no line states the default of --{option}"));
            let documented = stated_default(line.split(&needle).nth(1).unwrap()).unwrap();
            assert_same(
                &format!("{name}, {command} --{option}"),
                &documented,
                &default_of(command, option),
            );
        }
    }
}

#[test]
fn the_readmes_omega0_and_demo_steps_are_the_commands() {
    let readme = doc("README.md");
    let after = |needle: &str| {
        let rest = readme
            .split(needle)
            .nth(1)
            .unwrap_or_else(|| panic!("README.md no longer says {needle:?}"));
        leading_numbers(rest)
    };
    assert_same(
        "README, \"the default ω₀ =\"",
        &after("the default ω₀ = "),
        &default_of("train", "omega0"),
    );
    assert_same(
        "README, the demo's \"all N steps\"",
        &after("trains one 3-class model (all "),
        &default_of("demo", "steps"),
    );
    let training = doc("docs/training.md");
    let heading = training
        .lines()
        .find_map(|l| l.strip_prefix("## ω₀: "))
        .expect("docs/training.md's ω₀ section");
    assert_same(
        "docs/training.md, \"## ω₀: N by default\"",
        &leading_numbers(heading),
        &default_of("train", "omega0"),
    );
}

#[test]
fn the_parsing_reads_what_the_docs_write() {
    assert_eq!(leading_numbers("256,256,256,256"), [256.0; 4]);
    assert_eq!(leading_numbers("10⁻³, cosine to 10⁻⁴"), [1e-3]);
    assert_eq!(leading_numbers(" 1024 per class"), [1024.0]);
    assert!(leading_numbers("none").is_empty());
    assert_eq!(stated_default("(default 1.5, ≥ 1)"), Some(vec![1.5]));
    assert_eq!(stated_default("Default: 3000, or with"), Some(vec![3000.0]));
    assert_eq!(
        stated_default("(default: the model's time range at 21 times;"),
        Some(vec![21.0])
    );
}
