//! `axisctl completions SHELL` and `axisctl man`: generated from the same
//! parser that reads the command line, so they cannot drift from it.

use std::path::Path;

use anyhow::Context;

use crate::output;

fn parser() -> clap::Command {
    crate::cli::command(&super::exit::summary())
}

/// The shell's registration of dynamic completion: the script calls this
/// binary (by its full path, so it works off the PATH too) with
/// `AXISCTL_COMPLETE=SHELL` and the words typed, and shows what it answers.
pub fn completions(shell: clap_complete::Shell) -> anyhow::Result<()> {
    let shells = clap_complete::env::Shells::builtins();
    let name = shell.to_string();
    let completer = shells.completer(&name).with_context(|| format!("no completion for {name}"))?;
    let exe = std::env::current_exe().context("finding this binary for the completion script")?;
    let mut script = Vec::new();
    completer
        .write_registration(crate::cli::complete::VAR, "axisctl", "axisctl", &exe.to_string_lossy(), &mut script)
        .context("writing the completion script")?;
    output::text(format_args!("{}", String::from_utf8_lossy(&script)));
    Ok(())
}

pub fn man(dir: Option<&Path>) -> anyhow::Result<()> {
    match dir {
        None => {
            let mut page = Vec::new();
            clap_mangen::Man::new(parser()).render(&mut page).context("rendering the man page")?;
            output::text(format_args!("{}", String::from_utf8_lossy(&page)));
        }
        Some(dir) => {
            std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
            clap_mangen::generate_to(parser(), dir)
                .with_context(|| format!("writing the man pages to {}", dir.display()))?;
            output::line(format_args!("man pages written to {}", dir.display()));
        }
    }
    Ok(())
}
