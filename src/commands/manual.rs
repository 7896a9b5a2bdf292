//! `axisctl completions SHELL` and `axisctl man`: generated from the same
//! parser that reads the command line, so they cannot drift from it.

use std::path::Path;

use anyhow::Context;

use crate::output;

fn parser() -> clap::Command {
    crate::cli::command(&super::exit::summary())
}

pub fn completions(shell: clap_complete::Shell) -> anyhow::Result<()> {
    let mut script = Vec::new();
    clap_complete::generate(shell, &mut parser(), "axisctl", &mut script);
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
