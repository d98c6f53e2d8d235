//! `dynaslice man [-o DIR]`: manual pages (roff) generated from the command line's own
//! definitions (clap_mangen), so they never disagree with `--help`.

use super::console::{errln, out_bytes};
use anyhow::{Context, Result};
use clap::CommandFactory;
use dynaslice_output::write_atomically;
use dynaslice_output::Plan;

use std::path::PathBuf;

/// Arguments of `dynaslice man`.
#[derive(clap::Args, Debug)]
#[command(after_help = "\
Examples:
  dynaslice man | man -l -
  dynaslice man -o ~/.local/share/man/man1")]
pub struct Args {
    /// Directory for dynaslice.1 and one page per subcommand (dynaslice-train.1,
    /// dynaslice-eval-synthetic.1, …); without it, dynaslice.1 goes to standard output.
    #[arg(short, long, value_name = "DIR")]
    output: Option<PathBuf>,
    /// Replace existing pages in DIR.
    #[arg(long, requires = "output")]
    force: bool,
}

/// Runs `dynaslice man`.
pub fn run(a: Args) -> Result<()> {
    let mut cmd = super::Cli::command().disable_help_subcommand(true);
    // Built, the subcommands carry their display names (`dynaslice-eval-synthetic`).
    cmd.build();
    let Some(dir) = a.output else {
        let mut page = Vec::new();
        clap_mangen::Man::new(cmd).render(&mut page)?;
        out_bytes(&page)?;
        return Ok(());
    };
    let mut plan = Plan::new(std::iter::empty::<PathBuf>(), a.force);
    plan.directory("-o", &dir)?;
    let mut pages = Vec::new();
    render_pages(cmd, &mut pages)?;
    // Every page checked (none replaced without --force) before any is written.
    for (name, _) in &pages {
        plan.beside(&dir.join(name))?;
    }
    std::fs::create_dir_all(&dir)
        .with_context(|| format!("cannot create directory {}", dir.display()))?;
    for (name, page) in &pages {
        write_atomically(&dir.join(name), page)?;
    }
    errln!("wrote {} pages to {}", pages.len(), dir.display());
    Ok(())
}

/// The file name and page of `cmd` and of each of its subcommands.
fn render_pages(cmd: clap::Command, pages: &mut Vec<(String, Vec<u8>)>) -> Result<()> {
    for sub in cmd.get_subcommands().filter(|s| !s.is_hide_set()) {
        render_pages(sub.clone(), pages)?;
    }
    let man = clap_mangen::Man::new(cmd);
    let mut page = Vec::new();
    man.render(&mut page)?;
    pages.push((man.get_filename(), page));
    Ok(())
}
