//! `-d/--device` on a family's own commands (`state -d powercube:3`,
//! `pac-axis -d pac:2`, `cdios-status -d cdios:1/0`, or the names a bench
//! file gives): each device resolved through the bench to the one
//! [`Address`], checked to be of the command's family, before any link opens.
//! The per-family flags (`-m`, `--node`, axis numbers) are shorthand for the
//! same addresses. The whole-bench commands (`backup -d`, `commission -d`, ...)
//! take devices of any family on any link: [`any_family`].

use axisctl::bench::{self, Address, BenchError, BenchLink, DeviceRef};
use axisctl::family::Family;

use super::{usage, Ctx};

/// The devices `refs` name, in the order given and each once. They must be
/// devices of `family` on one link of the bench; that link becomes the
/// command's (a bench file may put the family on several). A device of
/// another family, an unknown name or a second link is a usage error.
pub fn of_family(ctx: &Ctx, family: Family, refs: &[DeviceRef]) -> anyhow::Result<Vec<Address>> {
    let named = resolved(ctx, refs)?;
    if let Some((r, at, _)) = named.iter().find(|(_, at, _)| at.family() != family) {
        return Err(usage(format!(
            "{command} takes {family} devices ({form}); {r} is a {other} device",
            command = ctx.command_name(),
            form = Address::form(family),
            other = at.family(),
        )));
    }
    if let Some((first, _, on)) = named.first() {
        if let Some((r, _, link)) = named.iter().find(|(_, _, link)| link.text != on.text) {
            return Err(usage(format!(
                "{first} is on {} and {r} on {}: a {family} command talks to one link; run it once per link",
                on.text, link.text,
            )));
        }
        ctx.pin_link(family, on);
    }
    Ok(named.into_iter().map(|(_, at, _)| at).collect())
}

/// The devices `refs` name, of any family, each with the link of the bench
/// it is reached on, in the order given and each once: what a whole-bench
/// command limited with `-d` works on. Nothing is opened. An unknown name,
/// or a family the one `--link` of old cannot reach (`-d pac:2` on a CAN
/// link), is a usage error.
pub fn any_family<'b>(ctx: &'b Ctx, refs: &[DeviceRef]) -> anyhow::Result<Vec<(Address, &'b BenchLink)>> {
    let bench = ctx.bench()?;
    let named = resolved(ctx, refs)?;
    if let Some((_, at, _)) = named.iter().find(|(_, at, link)| !bench::fits(&link.spec, at.family())) {
        return Err(BenchError::NoLink { family: at.family(), links: bench.describe() }.into());
    }
    Ok(named.into_iter().map(|(_, at, link)| (at, link)).collect())
}

/// Each device `refs` name as typed, its address and the link of the bench
/// it is on, in the order given and each address once.
fn resolved<'b, 'r>(
    ctx: &'b Ctx,
    refs: &'r [DeviceRef],
) -> anyhow::Result<Vec<(&'r DeviceRef, Address, &'b BenchLink)>> {
    let bench = ctx.bench()?;
    let mut out: Vec<(&DeviceRef, Address, &BenchLink)> = Vec::new();
    for r in refs {
        let at = bench.resolve(r)?;
        let link = bench.link_of(at)?;
        if !out.iter().any(|(_, a, _)| *a == at) {
            out.push((r, at, link));
        }
    }
    Ok(out)
}

/// Makes each family's link the one its `named` devices are on, for a
/// command that opens one session per family (`commission -d`). Devices of
/// one family on two links are a usage error.
pub fn pin_families(ctx: &Ctx, named: &[(Address, &BenchLink)]) -> anyhow::Result<()> {
    for (i, (at, link)) in named.iter().enumerate() {
        let two = named[..i].iter().find(|(a, l)| a.family() == at.family() && l.text != link.text);
        if let Some((first, l)) = two {
            return Err(usage(format!(
                "{first} is on {} and {at} on {}: {command} talks to the {family} on one link; run it once per link",
                l.text,
                link.text,
                command = ctx.command_name(),
                family = at.family(),
            )));
        }
    }
    for (at, link) in named {
        ctx.pin_link(at.family(), link);
    }
    Ok(())
}
