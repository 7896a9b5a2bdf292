//! The whole-bench `scan`, `halt --all` and `halt -d`: over every link of the bench and
//! every family on it, with the device layer's own scans and halts. They run
//! when the bench is more than the one `--link` of old (several links, or a
//! bench file); with one `--link` the PowerCube commands stay as they were.

use std::collections::BTreeSet;

use axisctl::bench::{Address, Bench, BenchLink, DeviceRef};
use axisctl::device::face::{Face, FaceError, Halt, MotionTarget};
use axisctl::device::registry;
use axisctl::family::Family;
use serde_json::{json, Map, Value};

use super::takeover::{self, HolderReport};
use super::{Ctx, NoAnswer, On};
use crate::output::{self, say};

/// The Cdios node every Cdios command defaults to (`--node 1`): probed on
/// every CAN link, beside the nodes the bench file names.
const DEFAULT_NODE: u8 = axisctl::family::CDIOS_FACTORY_NODE;

/// One device found by a scan.
struct Seen {
    address: Address,
    link: String,
    /// What the family says of it in a few words.
    detail: String,
}

/// Whether `scan` and `halt --all` go over the whole bench.
pub fn whole(ctx: &Ctx) -> anyhow::Result<bool> {
    Ok(!ctx.bench()?.is_single())
}

/// Each link opened once, for all the families on it.
fn share_links(ctx: &Ctx) {
    ctx.opener().keep_links_open();
}

/// The Cdios nodes probed on `link`.
fn cdios_nodes(link: &BenchLink) -> Vec<u8> {
    let named = link.devices.values().filter_map(|a| match a {
        Address::Cdios { node, .. } => Some(*node),
        _ => None,
    });
    let nodes: BTreeSet<u8> = std::iter::once(DEFAULT_NODE).chain(named).collect();
    nodes.into_iter().collect()
}

/// The sessions of `link`, for the registry's faces.
fn on<'a>(ctx: &'a Ctx, link: &'a BenchLink) -> On<'a> {
    On { opener: ctx.opener(), spec: &link.spec, opts: ctx.session_options() }
}

pub fn scan(ctx: &Ctx, ids: &[u8]) -> anyhow::Result<()> {
    let bench = ctx.bench()?;
    share_links(ctx);
    let mut seen = Vec::new();
    for (link, family) in bench.pairs() {
        for unit in registry::units(family, &cdios_nodes(link)) {
            let mut face = registry::open(family, unit, &mut on(ctx, link), ctx.retry)?;
            for f in face.discover(ids)? {
                let Ok(address) = Address::try_from(f.target) else { continue };
                seen.push(Seen { address, link: link.text.clone(), detail: f.detail });
            }
        }
    }
    let missing: Vec<(Option<&str>, Address, &str)> = bench
        .links()
        .iter()
        .flat_map(|l| l.devices.iter().map(move |(n, a)| (Some(n.as_str()), *a, l.text.as_str())))
        .filter(|(_, a, _)| !seen.iter().any(|s| s.address == *a))
        .collect();
    print_scan(ctx, bench, &seen, &missing);
    if seen.is_empty() {
        return Err(NoAnswer(format!("no device answered on any link of the bench: {}", bench.describe())).into());
    }
    if !missing.is_empty() {
        let names: Vec<_> = missing.iter().map(|(n, a, l)| format!("{} ({a} on {l})", n.unwrap_or("-"))).collect();
        return Err(NoAnswer(format!("expected but not answering: {}", names.join(", "))).into());
    }
    Ok(())
}

/// `scan -d DEVICE,...`: probes only the devices named, each on its link
/// through its family's face (the PowerCube modules named, the PA-CONTROL,
/// the Cdios node of each module named), and lists those that answered;
/// the others are missing (exit 4), as a bench file's expected devices are.
/// Every device is checked before a link opens.
pub fn scan_devices(ctx: &Ctx, refs: &[DeviceRef]) -> anyhow::Result<()> {
    let named = super::devices::any_family(ctx, refs)?;
    let bench = ctx.bench()?;
    share_links(ctx);
    // One face per link, family and unit (a Cdios node), in the order named.
    let mut units: Vec<(&BenchLink, Family, Option<u8>)> = Vec::new();
    for (at, link) in &named {
        let unit = registry::units(at.family(), &cdios_node(*at)).into_iter().next().flatten();
        if !units.iter().any(|(l, f, u)| l.text == link.text && *f == at.family() && *u == unit) {
            units.push((link, at.family(), unit));
        }
    }
    let mut seen = Vec::new();
    for (link, family, unit) in units {
        // The ids to probe where the family probes a range: the modules named.
        let ids: Vec<u8> = named
            .iter()
            .filter_map(|(at, l)| match at {
                Address::PowerCube { module } if l.text == link.text => Some(*module),
                _ => None,
            })
            .collect();
        let mut face = registry::open(family, unit, &mut on(ctx, link), ctx.retry)?;
        for f in face.discover(&ids)? {
            let Ok(address) = Address::try_from(f.target) else { continue };
            if named.iter().any(|(a, l)| *a == address && l.text == link.text) {
                seen.push(Seen { address, link: link.text.clone(), detail: f.detail });
            }
        }
    }
    let missing: Vec<(Option<&str>, Address, &str)> = named
        .iter()
        .filter(|(a, l)| !seen.iter().any(|s| s.address == *a && s.link == l.text))
        .map(|(a, l)| (bench.name_of(*a), *a, l.text.as_str()))
        .collect();
    print_scan(ctx, bench, &seen, &missing);
    if !missing.is_empty() {
        let names: Vec<_> = missing.iter().map(|(_, a, l)| format!("{a} (on {l})")).collect();
        return Err(NoAnswer(format!("named but not answering: {}", names.join(", "))).into());
    }
    Ok(())
}

/// The node of a Cdios device, as [`registry::units`] takes it.
fn cdios_node(at: Address) -> Vec<u8> {
    match at {
        Address::Cdios { node, .. } => vec![node],
        _ => Vec::new(),
    }
}

/// The envelope of docs/json.md for a device of the bench: family, link, the
/// one address (`null` for every device of a family on a link) and the
/// family's own address keys.
fn envelope(family: Family, link: &str, address: Option<Address>, node: Option<u8>) -> Map<String, Value> {
    let mut o = Map::new();
    o.insert("family".into(), family.name().into());
    o.insert("link".into(), link.into());
    o.insert("address".into(), address.map(|a| a.to_string()).into());
    match (address, family) {
        (Some(Address::PowerCube { module }), _) => _ = o.insert("module".into(), module.into()),
        (None, Family::PowerCube) => _ = o.insert("module".into(), Value::Null),
        (Some(Address::Pac { axis: Some(a) }), _) => _ = o.insert("axis".into(), a.into()),
        (Some(Address::Cdios { node, module }), _) => {
            o.insert("node".into(), node.into());
            o.insert("module".into(), module.into());
        }
        _ => {}
    }
    if let (Some(n), None) = (node, address) {
        o.insert("node".into(), n.into());
    }
    o
}

fn print_scan(ctx: &Ctx, bench: &Bench, seen: &[Seen], missing: &[(Option<&str>, Address, &str)]) {
    let name = |a: Address| bench.name_of(a).map(str::to_string);
    if ctx.json {
        let devices: Vec<Value> = seen
            .iter()
            .map(|s| {
                let mut o = envelope(s.address.family(), &s.link, Some(s.address), None);
                o.insert("name".into(), name(s.address).into());
                o.insert("detail".into(), s.detail.clone().into());
                Value::Object(o)
            })
            .collect();
        let missing: Vec<Value> = missing
            .iter()
            .map(|(n, a, l)| {
                let mut o = envelope(a.family(), l, Some(*a), None);
                o.insert("name".into(), (*n).into());
                Value::Object(o)
            })
            .collect();
        output::json(&json!({"devices": devices, "missing": missing}));
        return;
    }
    let mut rows = vec![["DEVICE", "NAME", "LINK", "DETAIL"].map(String::from).to_vec()];
    for s in seen {
        rows.push(vec![s.address.to_string(), name(s.address).unwrap_or("-".into()), s.link.clone(), s.detail.clone()]);
    }
    for (n, a, l) in missing {
        rows.push(vec![
            a.to_string(),
            n.unwrap_or("-").to_string(),
            l.to_string(),
            ctx.style.error("missing: no answer"),
        ]);
    }
    output::table(&rows, ctx.style);
}

/// One step of the whole-bench halt and how it went.
struct Step {
    link: String,
    family: Family,
    /// `None`: every device of the family on the link (a broadcast), or of
    /// the Cdios `node`.
    address: Option<Address>,
    node: Option<u8>,
    result: Result<String, anyhow::Error>,
}

/// The steps of a halt over the bench and the holders it took ports from:
/// every step is tried whatever the others did, then reported once.
#[derive(Default)]
struct Halts {
    steps: Vec<Step>,
    holders: Vec<HolderReport>,
}

impl Halts {
    /// Opens `family`'s face (the Cdios: of `node`) on `link`, taking the
    /// port over from an axisctl that holds it, and records what `stop`
    /// does with it, a step per device; `stop` returns `None` when there is
    /// nothing to report. A face that does not open is one failed step, of
    /// the device `at` when one was named.
    fn on(
        &mut self,
        ctx: &Ctx,
        link: &BenchLink,
        (family, node): (Family, Option<u8>),
        at: Option<Address>,
        stop: impl FnOnce(&mut dyn Face) -> Option<Vec<(Option<Address>, Result<Halt, FaceError>)>>,
    ) {
        let step = |address, result| Step { link: link.text.clone(), family, address, node, result };
        let opened = ctx.opener().take_over(|o| {
            let mut sessions = On { opener: o, spec: &link.spec, opts: ctx.session_options() };
            registry::open(family, node, &mut sessions, ctx.retry)
        });
        let (mut face, t) = match opened {
            Ok(x) => x,
            Err(e) => return self.steps.push(step(at, Err(e.into()))),
        };
        let Some(done) = stop(face.as_mut()) else { return };
        for (address, result) in done {
            self.steps.push(step(address, result.map(said).map_err(|e| takeover::failed(e, t.as_ref()))));
        }
        self.holders.extend(HolderReport::after_halt(t.as_ref()));
    }

    /// The report, then the first failure (its exit code) if a step failed.
    fn report(self, ctx: &Ctx, bench: &Bench, all: bool) -> anyhow::Result<()> {
        print_halt(ctx, bench, &self.steps, &self.holders, all);
        let failed = self.steps.iter().filter(|s| s.result.is_err()).count();
        let (what, unit) = if all { ("halt --all", "step(s) failed") } else { ("halt -d", "device(s) not stopped") };
        match self.steps.into_iter().find_map(|s| s.result.err()) {
            Some(first) => Err(first.context(format!("{what}: {failed} {unit}; see the report above"))),
            None => Ok(()),
        }
    }
}

pub fn halt_all(ctx: &Ctx) -> anyhow::Result<()> {
    let bench = ctx.bench()?;
    share_links(ctx);
    let mut halts = Halts::default();
    for (link, family) in bench.pairs() {
        for unit in registry::units(family, &cdios_nodes(link)) {
            halts.on(ctx, link, (family, unit), None, |face| {
                // The face's own sequence: it finds its devices and stops each.
                let done = face.halt_all(None);
                // The default Cdios node, absent and not expected: nothing to stop.
                let absent = matches!(&done[..], [one] if one.target.is_none() && one.result.is_err());
                if absent && unit == Some(DEFAULT_NODE) && !bench.links().iter().any(|l| named_node(l, DEFAULT_NODE)) {
                    return None;
                }
                Some(done.into_iter().map(|s| (s.target.and_then(|t| Address::try_from(t).ok()), s.result)).collect())
            });
        }
    }
    halts.report(ctx, bench, true)
}

/// `halt -d DEVICE,...`: a person's stop of each device named, through its
/// family's face on its link; a device at rest is "already at rest". Every
/// address is checked before the first link opens, so a bad one sends
/// nothing. Each device is tried whatever the others did.
pub fn halt_devices(ctx: &Ctx, devices: &[DeviceRef]) -> anyhow::Result<()> {
    let bench = ctx.bench()?;
    let mut named: Vec<(Address, &BenchLink, MotionTarget)> = Vec::new();
    for (at, link) in super::devices::any_family(ctx, devices)? {
        let target = MotionTarget::try_from(at)
            .map_err(|_| super::usage(format!("{at} is not a device its family can stop")))?;
        named.push((at, link, target));
    }
    share_links(ctx);
    let mut halts = Halts::default();
    for (at, link, target) in named {
        halts.on(ctx, link, (at.family(), target.node()), Some(at), |face| Some(vec![(Some(at), face.stop(target))]));
    }
    halts.report(ctx, bench, false)
}

/// How the report says a step went.
fn said(h: Halt) -> String {
    match h {
        Halt::Broadcast => "broadcast Halt sent".into(),
        Halt::Halted => "halted".into(),
        Halt::StoppedAt(at) => format!("stopped at {at}"),
        Halt::FastStop { .. } => "fast stop".into(),
        Halt::AtRest => "already at rest".into(),
        Halt::Steps(said) => said,
    }
}

fn named_node(link: &BenchLink, node: u8) -> bool {
    link.devices.values().any(|a| matches!(a, Address::Cdios { node: n, .. } if *n == node))
}

fn print_halt(ctx: &Ctx, bench: &Bench, steps: &[Step], holders: &[HolderReport], all: bool) {
    let address = |s: &Step| match (s.address, s.node) {
        (Some(a), _) => a.to_string(),
        (None, Some(n)) => format!("{}:{n}/*", s.family.name()),
        (None, None) => format!("{} (all)", s.family.name()),
    };
    if ctx.json {
        let list: Vec<Value> = steps
            .iter()
            .map(|s| {
                let mut o = envelope(s.family, &s.link, s.address, s.node);
                o.insert("name".into(), s.address.and_then(|a| bench.name_of(a)).into());
                o.insert("ok".into(), s.result.is_ok().into());
                match &s.result {
                    Ok(what) => o.insert("result".into(), what.clone().into()),
                    Err(e) => o.insert("error".into(), format!("{e:#}").into()),
                };
                Value::Object(o)
            })
            .collect();
        let holders: Vec<Value> = holders.iter().map(HolderReport::json).collect();
        output::json(&json!({"command": "halt", "all": all, "steps": list, "holders": holders}));
        return;
    }
    for h in holders {
        say!("{}", h.line());
    }
    let mut rows = vec![["DEVICE", "LINK", "RESULT"].map(String::from).to_vec()];
    for s in steps {
        let result = match &s.result {
            Ok(what) => what.clone(),
            Err(e) => ctx.style.error(&format!("FAILED: {e:#}")),
        };
        rows.push(vec![address(s), s.link.clone(), result]);
    }
    output::table(&rows, ctx.style);
}
