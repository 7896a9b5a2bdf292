//! Did-you-mean for subcommands. clap's own suggestion compares whole
//! names, and the families' shared prefixes (`pac-`, `cdios-`) make every
//! command of a family look alike: `pac-axsi` drew 16 suggestions. Here a
//! name is compared by edit distance, so a typo gets the few names it is
//! one or two edits from.

use clap::error::{ContextKind, ContextValue, ErrorKind};

/// Names within this many edits (a swap counts once) are suggested; a
/// long name may be a few more edits away.
fn max_edits(typed: &str) -> usize {
    (typed.len() / 4).max(2)
}

/// The names of `names` closest to `typed`, at most three, best first.
pub fn closest<'a>(typed: &str, names: impl IntoIterator<Item = &'a str>) -> Vec<&'a str> {
    let typed = typed.to_ascii_lowercase();
    let mut near: Vec<(usize, &str)> = names
        .into_iter()
        .map(|n| (strsim::damerau_levenshtein(&typed, &n.to_ascii_lowercase()), n))
        .filter(|(d, _)| *d <= max_edits(&typed))
        .collect();
    near.sort_by_key(|(d, _)| *d);
    if let Some(&(best, _)) = near.first() {
        near.retain(|(d, _)| *d == best);
    }
    near.dedup_by_key(|(_, n)| n.to_ascii_lowercase());
    near.into_iter().take(3).map(|(_, n)| n).collect()
}

/// An unknown subcommand's error with its suggestion replaced by ours;
/// every other error as it was.
pub fn subcommand(err: clap::Error, cmd: &clap::Command) -> clap::Error {
    if err.kind() != ErrorKind::InvalidSubcommand {
        return err;
    }
    let Some(ContextValue::String(typed)) = err.get(ContextKind::InvalidSubcommand) else { return err };
    let names = cmd.get_subcommands().flat_map(|c| std::iter::once(c.get_name()).chain(c.get_all_aliases()));
    let near = closest(typed, names);
    let mut out = clap::Error::new(ErrorKind::InvalidSubcommand).with_cmd(cmd);
    out.insert(ContextKind::InvalidSubcommand, ContextValue::String(typed.clone()));
    if !near.is_empty() {
        let list = near.into_iter().map(String::from).collect();
        out.insert(ContextKind::SuggestedSubcommand, ContextValue::Strings(list));
    }
    if let Some(usage) = err.get(ContextKind::Usage) {
        out.insert(ContextKind::Usage, usage.clone());
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn names() -> Vec<String> {
        crate::cli::command("").get_subcommands().map(|c| c.get_name().to_string()).collect()
    }

    #[test]
    fn a_typo_gets_the_command_it_is_near() {
        let names = names();
        let names = || names.iter().map(String::as_str);
        assert_eq!(closest("pac-axsi", names()), ["pac-axis"]);
        assert_eq!(closest("cdios-goot", names()), ["cdios-goto"]);
        assert_eq!(closest("mvoe-ramp", names()), ["move-ramp"]);
        assert_eq!(closest("PAC-STATE", names()), ["pac-state"]);
        assert!(closest("frobnicate", names()).is_empty());
    }

    #[test]
    fn the_error_suggests_one_command_not_a_family() {
        let mut cmd = crate::cli::command("");
        let err = cmd.try_get_matches_from_mut(["axisctl", "pac-axsi"]).unwrap_err();
        let text = subcommand(err, &cmd).render().to_string();
        assert!(text.contains("unrecognized subcommand 'pac-axsi'"), "{text}");
        assert!(text.contains("'pac-axis'") && !text.contains("pac-axes") && !text.contains("pac-online"), "{text}");
        assert!(text.contains("Usage: axisctl"), "{text}");
    }
}
