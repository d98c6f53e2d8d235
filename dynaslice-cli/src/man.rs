//! `dynaslice man [-o DIR]`: manual pages (roff) generated from the command line's own
//! definitions (clap_mangen), so they never disagree with `--help`.

use super::console::{errln, out_bytes};
use super::output::Plan;
use anyhow::{Context, Result};
use clap::CommandFactory;
use dynaslice_data::atomic::write_atomically;
use std::path::{Path, PathBuf};

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
    Plan::new(std::iter::empty::<PathBuf>(), true).directory("-o", &dir)?;
    std::fs::create_dir_all(&dir)
        .with_context(|| format!("cannot create directory {}", dir.display()))?;
    let written = write_pages(cmd, &dir)?;
    errln!("wrote {written} pages to {}", dir.display());
    Ok(())
}

/// Writes the page of `cmd` and of each of its subcommands, each atomically; returns the count.
fn write_pages(cmd: clap::Command, dir: &Path) -> Result<usize> {
    let mut written = 0;
    for sub in cmd.get_subcommands().filter(|s| !s.is_hide_set()) {
        written += write_pages(sub.clone(), dir)?;
    }
    let man = clap_mangen::Man::new(cmd);
    let mut page = Vec::new();
    man.render(&mut page)?;
    write_atomically(&dir.join(man.get_filename()), &page)?;
    Ok(written + 1)
}
