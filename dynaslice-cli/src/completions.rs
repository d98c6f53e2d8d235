//! `dynaslice completions SHELL`: the shell's completion script for every subcommand and
//! option, on standard output (clap_complete).

use super::console::out_bytes;
use anyhow::Result;
use clap::CommandFactory;
use clap_complete::Shell;

/// Arguments of `dynaslice completions`.
#[derive(clap::Args, Debug)]
#[command(after_help = "\
Install, e.g.:
  bash:  dynaslice completions bash > ~/.local/share/bash-completion/completions/dynaslice
  zsh:   dynaslice completions zsh > ~/.zfunc/_dynaslice   (with fpath+=~/.zfunc)
  fish:  dynaslice completions fish > ~/.config/fish/completions/dynaslice.fish")]
pub struct Args {
    /// The shell: bash, zsh, fish, elvish or powershell.
    shell: Shell,
}

/// Runs `dynaslice completions`: writes the script to standard output.
pub fn run(a: Args) -> Result<()> {
    let mut cmd = super::Cli::command();
    // Rendered in memory first: clap_complete panics when its writer fails (a closed pipe).
    let mut script = Vec::new();
    clap_complete::generate(a.shell, &mut cmd, "dynaslice", &mut script);
    out_bytes(&script)?;
    Ok(())
}
