//! `-d/--device` on a family's own commands (`state -d powercube:3`,
//! `pac-axis -d pac:2`, `cdios-status -d cdios:1/0`, or the names a bench
//! file gives): each device resolved through the bench to the one
//! [`Address`], checked to be of the command's family, before any link opens.
//! The per-family flags (`-m`, `--node`, axis numbers) are shorthand for the
//! same addresses.

use axisctl::bench::{Address, DeviceRef};
use axisctl::family::Family;

use super::{usage, Ctx};

/// The devices `refs` name, in the order given and each once. They must be
/// devices of `family` on one link of the bench; that link becomes the
/// command's (a bench file may put the family on several). A device of
/// another family, an unknown name or a second link is a usage error.
pub fn of_family(ctx: &Ctx, family: Family, refs: &[DeviceRef]) -> anyhow::Result<Vec<Address>> {
    let bench = ctx.bench()?;
    let mut out: Vec<Address> = Vec::new();
    let mut on: Option<(&DeviceRef, &axisctl::bench::BenchLink)> = None;
    for r in refs {
        let at = bench.resolve(r)?;
        if at.family() != family {
            return Err(usage(format!(
                "{command} takes {family} devices ({form}); {r} is a {other} device",
                command = ctx.command_name(),
                form = Address::form(family),
                other = at.family(),
            )));
        }
        let link = bench.link_of(at)?;
        match on {
            Some((first, l)) if l.text != link.text => {
                return Err(usage(format!(
                    "{first} is on {} and {r} on {}: a {family} command talks to one link; run it once per link",
                    l.text, link.text,
                )));
            }
            None => on = Some((r, link)),
            Some(_) => {}
        }
        if !out.contains(&at) {
            out.push(at);
        }
    }
    if let Some((_, link)) = on {
        ctx.pin_link(family, link);
    }
    Ok(out)
}
