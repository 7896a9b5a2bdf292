//! The whole-bench `scan` and `halt --all`: over every link of the bench and
//! every family on it, with the device layer's own scans and halts. They run
//! when the bench is more than the one `--link` of old (several links, or a
//! bench file); with one `--link` the PowerCube commands stay as they were.

use std::collections::BTreeSet;

use axisctl::bench::{Address, Bench, BenchLink};
use axisctl::device::cdios::{Node, Stopped};
use axisctl::device::pac::{Controller, HaltTarget};
use axisctl::device::powercube::{Cubes, Simple};
use axisctl::family::Family;
use axisctl::proto::{cdios, powercube};
use serde_json::{json, Map, Value};

use super::takeover::{self, HolderReport};
use super::{Ctx, NoAnswer};
use crate::output::{self, say};

/// The Cdios node every Cdios command defaults to (`--node 1`): probed on
/// every CAN link, beside the nodes the bench file names.
const DEFAULT_NODE: u8 = 1;

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
fn cdios_nodes(link: &BenchLink) -> Vec<cdios::NodeId> {
    let named = link.devices.values().filter_map(|a| match a {
        Address::Cdios { node, .. } => Some(*node),
        _ => None,
    });
    let nodes: BTreeSet<u8> = std::iter::once(DEFAULT_NODE).chain(named).collect();
    nodes.into_iter().filter_map(cdios::NodeId::new).collect()
}

pub fn scan(ctx: &Ctx, ids: &[u8]) -> anyhow::Result<()> {
    let bench = ctx.bench()?;
    share_links(ctx);
    let opts = ctx.session_options();
    let mut seen = Vec::new();
    for (link, family) in bench.pairs() {
        let text = || link.text.clone();
        match family {
            Family::PowerCube => {
                let mut cubes = Cubes::new(ctx.opener().powercube(&link.spec, &opts)?);
                let candidates: Vec<_> = ids.iter().filter_map(|m| powercube::ModuleId::new(*m)).collect();
                for f in cubes.scan(&candidates)? {
                    let version = f.version.as_f64().unwrap_or(f64::NAN) as u16;
                    seen.push(Seen {
                        address: Address::PowerCube { module: f.module.get() },
                        link: text(),
                        detail: format!("version {}", axisctl::device::powercube::version_text(version)),
                    });
                }
            }
            Family::Pac => {
                let mut d = Controller::new(ctx.opener().pac(&link.spec, &opts)?);
                // A controller that does not answer is absent, as a module is.
                let Ok(status) = d.status() else { continue };
                let axes = d.configured_axes()?;
                seen.push(Seen {
                    address: Address::Pac { axis: None },
                    link: text(),
                    detail: format!(
                        "status {status} {}, {axes} axes",
                        axisctl::proto::pac::table::operating_status_text(status)
                    ),
                });
                for axis in 1..=axes {
                    seen.push(Seen { address: Address::Pac { axis: Some(axis) }, link: text(), detail: String::new() });
                }
            }
            Family::Cdios => {
                for node in cdios_nodes(link) {
                    let mut n = Node::new(ctx.opener().cdios(&link.spec, &opts)?, node, ctx.retry);
                    // A node that does not wake is absent: its modules are reported missing if expected.
                    let Ok(found) = n.scan() else { continue };
                    for m in found {
                        let address = Address::Cdios { node: node.get(), module: m.get() };
                        seen.push(Seen { address, link: text(), detail: String::new() });
                    }
                }
            }
        }
    }
    let missing: Vec<(&str, Address, &str)> = bench
        .links()
        .iter()
        .flat_map(|l| l.devices.iter().map(move |(n, a)| (n.as_str(), *a, l.text.as_str())))
        .filter(|(_, a, _)| !seen.iter().any(|s| s.address == *a))
        .collect();
    print_scan(ctx, bench, &seen, &missing);
    if seen.is_empty() {
        return Err(NoAnswer(format!("no device answered on any link of the bench: {}", bench.describe())).into());
    }
    if !missing.is_empty() {
        let names: Vec<_> = missing.iter().map(|(n, a, l)| format!("{n} ({a} on {l})")).collect();
        return Err(NoAnswer(format!("expected but not answering: {}", names.join(", "))).into());
    }
    Ok(())
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

fn print_scan(ctx: &Ctx, bench: &Bench, seen: &[Seen], missing: &[(&str, Address, &str)]) {
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
        rows.push(vec![a.to_string(), n.to_string(), l.to_string(), ctx.style.error("missing: no answer")]);
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

pub fn halt_all(ctx: &Ctx) -> anyhow::Result<()> {
    let bench = ctx.bench()?;
    share_links(ctx);
    let opts = ctx.session_options();
    let mut steps = Vec::new();
    let mut holders = Vec::new();
    for (link, family) in bench.pairs() {
        let step = |address, result| Step { link: link.text.clone(), family, address, node: None, result };
        match family {
            Family::PowerCube => {
                let opened = ctx.opener().take_over(|o| o.powercube(&link.spec, &opts));
                let (pc, t) = match opened {
                    Ok(x) => x,
                    Err(e) => {
                        steps.push(step(None, Err(e.into())));
                        continue;
                    }
                };
                let mut cubes = Cubes::new(pc);
                let broadcast = cubes.simple(None, Simple::Halt);
                let broadcast = broadcast.map(|()| "broadcast Halt sent".to_string());
                steps.push(step(None, broadcast.map_err(|e| takeover::failed(e, t.as_ref()))));
                // Then each module that answers, acknowledged: a lost broadcast is seen.
                let all: Vec<_> = (1..=31).filter_map(powercube::ModuleId::new).collect();
                match cubes.scan(&all) {
                    Ok(found) => {
                        for f in found {
                            let r = cubes.simple(Some(f.module), Simple::Halt).map(|()| "halted".to_string());
                            steps
                                .push(step(Some(Address::PowerCube { module: f.module.get() }), r.map_err(Into::into)));
                        }
                    }
                    Err(e) => steps.push(step(None, Err(e.into()))),
                }
                holders.extend(HolderReport::after_halt(t.as_ref()));
            }
            Family::Pac => {
                let (pac, t) = match ctx.opener().take_over(|o| o.pac(&link.spec, &opts)) {
                    Ok(x) => x,
                    Err(e) => {
                        steps.push(step(None, Err(e.into())));
                        continue;
                    }
                };
                let mut d = Controller::new(pac);
                // The axes to stop in online mode; unknown, halt-all stops the program (0600).
                let axes = d.configured_axes().map(|n| (1..=n).collect()).unwrap_or_default();
                d.set_axes(axes);
                for s in d.halt_all() {
                    let address = match s.target {
                        HaltTarget::Controller => Address::Pac { axis: None },
                        HaltTarget::Axis(a) => Address::Pac { axis: Some(a) },
                    };
                    steps.push(step(Some(address), s.result.map_err(|e| takeover::failed(e, t.as_ref()))));
                }
                holders.extend(HolderReport::after_halt(t.as_ref()));
            }
            Family::Cdios => {
                for node in cdios_nodes(link) {
                    let on_node = |result| Step { node: Some(node.get()), ..step(None, result) };
                    let (s, t) = match ctx.opener().take_over(|o| o.cdios(&link.spec, &opts)) {
                        Ok(x) => x,
                        Err(e) => {
                            steps.push(on_node(Err(e.into())));
                            continue;
                        }
                    };
                    let mut n = Node::new(s, node, ctx.retry);
                    let modules = match n.scan() {
                        Ok(m) => m,
                        Err(e) if node.get() != DEFAULT_NODE || bench.links().iter().any(|l| named_node(l, node)) => {
                            steps.push(on_node(Err(e.into())));
                            continue;
                        }
                        // The default node, absent and not expected: nothing to stop.
                        Err(_) => continue,
                    };
                    for (m, r) in n.halt_all(&modules) {
                        let said = r.map(|s| match s {
                            Stopped::FastStop { .. } => "fast stop".to_string(),
                            Stopped::NotRunning => "already at rest".to_string(),
                        });
                        let address = Address::Cdios { node: node.get(), module: m.get() };
                        steps.push(step(Some(address), said.map_err(|e| takeover::failed(e, t.as_ref()))));
                    }
                    holders.extend(HolderReport::after_halt(t.as_ref()));
                }
            }
        }
    }
    print_halt(ctx, bench, &steps, &holders);
    let failed = steps.iter().filter(|s| s.result.is_err()).count();
    match steps.into_iter().find_map(|s| s.result.err()) {
        Some(first) => Err(first.context(format!("halt --all: {failed} step(s) failed; see the report above"))),
        None => Ok(()),
    }
}

fn named_node(link: &BenchLink, node: cdios::NodeId) -> bool {
    link.devices.values().any(|a| matches!(a, Address::Cdios { node: n, .. } if *n == node.get()))
}

fn print_halt(ctx: &Ctx, bench: &Bench, steps: &[Step], holders: &[HolderReport]) {
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
        output::json(&json!({"command": "halt", "all": true, "steps": list, "holders": holders}));
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
