//! `axisctl backup`, `diff` and `restore`: thin adapters over
//! `axisctl::backup` (the document, the diff engine, the checks and the
//! write order live there).

use std::collections::BTreeSet;
use std::path::Path;

use axisctl::backup::{self, Address, Device, Difference, Document, Problem, ValueResult};
use axisctl::device::cdios::{Node, Slot};
use axisctl::device::pac::Controller;
use axisctl::device::powercube::{Cubes, Error as CubeError};
use axisctl::device::supervisor;
use axisctl::family::{Family, CDIOS_MODULE, POWERCUBE_MODULE};
use axisctl::link::LinkSpec;
use axisctl::proto::cdios::{ModuleId as CdiosModule, NodeId};
use axisctl::proto::powercube::ModuleId;
use axisctl::session::ErrorKind;
use serde_json::{json, Value};

use super::{usage, Ctx, Interrupted};
use crate::cli::backup::{BackupCommand, Selection};
use crate::cli::ids::Devices;
use crate::output::{self, say};

pub fn run(ctx: &Ctx, cmd: BackupCommand) -> anyhow::Result<()> {
    match cmd {
        BackupCommand::Backup { select, out } => save(ctx, &select, out.as_deref()),
        BackupCommand::Diff { file, file2 } => diff(ctx, &file, file2.as_deref()),
        BackupCommand::Restore { file, dry_run, skip_invalid, to, store } => {
            restore(ctx, &file, Options { dry_run, skip_invalid, to, store })
        }
    }
}

/// The families a backup reads: those named, else every family the link
/// carries (a serial line carries one, which must be named).
fn families(ctx: &Ctx, named: &[Family]) -> anyhow::Result<Vec<Family>> {
    let link = ctx.link()?;
    let fits = |f: Family| match link {
        LinkSpec::Sim(_) => true,
        LinkSpec::Serial { .. } => f.link_kind().rs232(),
        _ => f.link_kind().can(),
    };
    if let Some(f) = named.iter().find(|f| !fits(**f)) {
        return Err(usage(format!("{link} does not carry the {f}")));
    }
    if !named.is_empty() {
        return Ok(Family::ALL.into_iter().filter(|f| named.contains(f)).collect());
    }
    if matches!(link, LinkSpec::Serial { .. }) {
        return Err(usage(format!(
            "{link} is a serial line, which carries one family: name it with --family powercube or --family pac"
        )));
    }
    Ok(Family::ALL.into_iter().filter(|f| fits(*f)).collect())
}

/// The sessions of the command, opened when first needed.
struct Live<'a> {
    ctx: &'a Ctx,
    cubes: Option<Cubes>,
    pac: Option<Controller>,
    /// Cdios nodes by id, with the controller's identify answer.
    nodes: Vec<(Node, Vec<Slot>)>,
}

impl<'a> Live<'a> {
    fn new(ctx: &'a Ctx) -> Self {
        Self { ctx, cubes: None, pac: None, nodes: Vec::new() }
    }

    fn cubes(&mut self) -> anyhow::Result<&mut Cubes> {
        if self.cubes.is_none() {
            self.cubes = Some(Cubes::new(self.ctx.powercube()?));
        }
        Ok(self.cubes.as_mut().expect("opened above"))
    }

    /// The node and its slots, opened and identified once.
    fn node(&mut self, id: u8) -> anyhow::Result<&mut (Node, Vec<Slot>)> {
        if !self.nodes.iter().any(|(n, _)| n.id().get() == id) {
            let node_id = NodeId::new(id).ok_or_else(|| usage(format!("node {id}: a Cdios node id is 1 to 127")))?;
            let mut node = Node::new(self.ctx.cdios()?, node_id, self.ctx.retry);
            let slots = node.identify()?;
            self.nodes.push((node, slots));
        }
        Ok(self.nodes.iter_mut().find(|(n, _)| n.id().get() == id).expect("opened above"))
    }

    fn pac(&mut self) -> anyhow::Result<&mut Controller> {
        if self.pac.is_none() {
            self.pac = Some(Controller::new(self.ctx.pac()?));
        }
        Ok(self.pac.as_mut().expect("opened above"))
    }

    /// The devices of `family` the selection names, or those present.
    fn present(&mut self, family: Family, select: &Selection, named: bool) -> anyhow::Result<Vec<Address>> {
        let addr = |module| Address { family, module, axis: None, node: None };
        match family {
            Family::PowerCube => {
                let ids: Vec<u8> = match &select.module {
                    Some(Devices::One(id)) => vec![*id],
                    Some(Devices::List(list)) => list.0.clone(),
                    Some(Devices::All) | None => {
                        let found: Vec<u8> = self.cubes()?.present()?.iter().map(|m| m.get()).collect();
                        if found.is_empty() && named {
                            let ids = format!("{}-{}", POWERCUBE_MODULE.min, POWERCUBE_MODULE.max);
                            return Err(CubeError::NoneAnswered { ids }.into());
                        }
                        found
                    }
                };
                Ok(ids.into_iter().map(|id| addr(Some(id))).collect())
            }
            Family::Pac => {
                let c = self.pac()?;
                backup::pac::ensure_home(c)?;
                let n = c.configured_axes()?;
                let axes = (1..=n).map(|a| Address { axis: Some(a), ..addr(None) });
                Ok(std::iter::once(addr(None)).chain(axes).collect())
            }
            Family::Cdios => {
                target(Address { family, module: None, axis: None, node: Some(select.node) });
                let (node, _) = match self.node(select.node) {
                    Ok(n) => n,
                    // A CAN bus without the node: no Cdios device, unless asked for.
                    Err(_) if !named => return Ok(Vec::new()),
                    Err(e) => return Err(e),
                };
                let found = node.scan()?;
                Ok(found
                    .iter()
                    .map(|m| Address { family, module: Some(m.get()), axis: None, node: Some(select.node) })
                    .collect())
            }
        }
    }

    /// The live device at `at`, read into the backup's shape.
    fn capture(&mut self, at: Address) -> anyhow::Result<Device> {
        target(at);
        let link = self.ctx.link_text.clone();
        match at.family {
            Family::PowerCube => Ok(backup::powercube::capture(self.cubes()?, module(at)?, &link)?),
            Family::Pac => Ok(match at.axis {
                None => backup::pac::capture_controller(self.pac()?, &link)?,
                Some(a) => backup::pac::capture_axis(self.pac()?, a, &link)?,
            }),
            Family::Cdios => {
                let m = cdios_module(at)?;
                let (node, slots) = self.node(at.node.unwrap_or(1))?;
                let slot = slots.iter().find(|s| s.module == m.get()).copied();
                let (ty, version) = slot.map_or((0, 0), |s| (s.ty, s.version));
                Ok(backup::cdios::capture(node, m, ty, version, &link)?)
            }
        }
    }

    fn check_live(&mut self, file: &Device, live: &Device) -> anyhow::Result<Vec<Problem>> {
        target(file.address());
        Ok(match file.family {
            Family::PowerCube => backup::powercube::check_live(file, live),
            Family::Pac => backup::pac::check_live(self.pac()?, file, live)?,
            Family::Cdios => backup::cdios::check_live(file, live),
        })
    }

    fn restore(
        &mut self,
        file: &Device,
        live: &Device,
        skip: &BTreeSet<String>,
        stop: backup::Stop<'_>,
    ) -> anyhow::Result<Vec<ValueResult>> {
        let at = live.address();
        target(at);
        match at.family {
            Family::PowerCube => {
                let m = module(at)?;
                Ok(backup::powercube::restore(self.cubes()?, m, file, live, skip, stop)?)
            }
            Family::Pac => Ok(backup::pac::restore(self.pac()?, file, live, skip, stop)?),
            Family::Cdios => {
                let m = cdios_module(at)?;
                let (node, _) = self.node(at.node.unwrap_or(1))?;
                Ok(backup::cdios::restore(node, m, file, live, skip, stop)?)
            }
        }
    }

    /// Refuses a device that moves (or a PA-CONTROL out of home position):
    /// asked of every device before the first write.
    fn ensure_at_rest(&mut self, at: Address) -> anyhow::Result<()> {
        target(at);
        match at.family {
            Family::PowerCube => {
                let m = module(at)?;
                Ok(backup::powercube::ensure_at_rest(self.cubes()?, m)?)
            }
            Family::Pac => Ok(backup::pac::ensure_home(self.pac()?)?),
            Family::Cdios => {
                let m = cdios_module(at)?;
                let (node, _) = self.node(at.node.unwrap_or(1))?;
                Ok(backup::cdios::ensure_at_rest(node, m)?)
            }
        }
    }

    /// The Cdios EEPROM store (05h) of one module.
    fn store(&mut self, at: Address) -> anyhow::Result<()> {
        target(at);
        let m = cdios_module(at)?;
        let (node, _) = self.node(at.node.unwrap_or(1))?;
        Ok(backup::cdios::store(node, m)?)
    }
}

/// Why the writes stop, as each value not written says it.
fn stop_text(sig: i32) -> String {
    format!("the restore stopped on {}", supervisor::signal_name(sig))
}

fn cdios_module(at: Address) -> anyhow::Result<CdiosModule> {
    at.module.and_then(CdiosModule::new).ok_or_else(|| usage(format!("{at}: no Cdios module id 0 to 15")))
}

fn module(at: Address) -> anyhow::Result<ModuleId> {
    at.module.and_then(ModuleId::new).ok_or_else(|| usage(format!("{at}: no PowerCube module id 1 to 31")))
}

/// Records the device being addressed, for the error object.
fn target(at: Address) {
    let mut addr: Vec<(&'static str, u64)> = Vec::new();
    addr.extend(at.node.map(|n| ("node", n.into())));
    addr.extend(at.module.map(|m| ("module", m.into())));
    addr.extend(at.axis.map(|a| ("axis", a.into())));
    output::target(at.family, &addr);
}

/// The envelope of a device in a report.
fn envelope(at: Address, link: &str) -> serde_json::Map<String, Value> {
    let mut doc = serde_json::Map::new();
    doc.insert("family".into(), at.family.name().into());
    doc.insert("link".into(), link.into());
    for (k, v) in [("node", at.node), ("module", at.module), ("axis", at.axis)] {
        if let Some(v) = v {
            doc.insert(k.into(), v.into());
        }
    }
    doc
}

fn save(ctx: &Ctx, select: &Selection, out: Option<&Path>) -> anyhow::Result<()> {
    // -m names PowerCube modules: alone, it selects them only.
    let named = if select.family.is_empty() && select.module.is_some() {
        vec![Family::PowerCube]
    } else {
        select.family.clone()
    };
    let families = families(ctx, &named)?;
    if select.module.is_some() && !families.contains(&Family::PowerCube) {
        return Err(usage("-m names PowerCube modules, but the backup reads no PowerCube"));
    }
    let named = !named.is_empty();
    let mut live = Live::new(ctx);
    let mut doc = Document {
        schema: backup::SCHEMA.into(),
        created_by: format!("axisctl {}", env!("AXISCTL_VERSION")),
        link: ctx.link_text.clone(),
        devices: Vec::new(),
    };
    for f in families {
        for at in live.present(f, select, named)? {
            doc.devices.push(live.capture(at)?);
        }
    }
    output::forget_target();
    let text = serde_json::to_string_pretty(&doc)?;
    let Some(path) = out else {
        say!("{text}");
        return Ok(());
    };
    std::fs::write(path, format!("{text}\n")).map_err(|e| anyhow::anyhow!("cannot write {}: {e}", path.display()))?;
    let devices: Vec<Value> = doc.devices.iter().map(|d| Value::Object(envelope(d.address(), &d.link))).collect();
    if ctx.json {
        output::json(&json!({"command": "backup", "file": path.display().to_string(), "schema": backup::SCHEMA,
                             "devices": devices}));
    } else {
        let n = doc.devices.len();
        say!("{n} device{} saved to {}", plural(n), path.display());
        for d in &doc.devices {
            say!("  {}: {} settings", d.address(), d.restorable().count());
        }
    }
    Ok(())
}

/// Reads and parses a backup (`-` is stdin): exit 2 before anything opens
/// when it is not one this axisctl reads.
fn read_file(path: &Path) -> anyhow::Result<Document> {
    let text = super::input::read_text(path, super::input::BACKUP, "a backup")?;
    Ok(backup::parse(&path.display().to_string(), &text)?)
}

/// The live bench in the shape of `file`: each of its devices read at its
/// own address.
fn capture_like(live: &mut Live, file: &Document) -> anyhow::Result<Document> {
    let mut devices = Vec::new();
    for d in &file.devices {
        devices.push(live.capture(d.address())?);
    }
    output::forget_target();
    Ok(Document { devices, link: live.ctx.link_text.clone(), ..file.clone() })
}

fn diff_json(diffs: &[backup::DeviceDiff]) -> Vec<Value> {
    diffs
        .iter()
        .map(|d| {
            let mut obj = envelope(d.address, &d.link);
            obj.insert("differs".into(), (!d.differences.is_empty()).into());
            obj.insert("differences".into(), serde_json::to_value(&d.differences).unwrap_or_default());
            Value::Object(obj)
        })
        .collect()
}

fn show(v: &Option<Value>) -> String {
    match v {
        None => "-".into(),
        Some(Value::String(s)) => s.clone(),
        Some(v) => v.to_string(),
    }
}

/// The diff as a table: device, setting, unit, left, right.
fn print_diff(ctx: &Ctx, diffs: &[backup::DeviceDiff], left: &str, right: &str) {
    let n: usize = diffs.iter().map(|d| d.differences.len()).sum();
    if n == 0 {
        say!("no differences ({} device{})", diffs.len(), plural(diffs.len()));
        return;
    }
    let mut rows = vec![vec!["DEVICE".into(), "SETTING".into(), "UNIT".into(), left.to_string(), right.to_string()]];
    for d in diffs {
        for Difference { name, unit, left, right } in &d.differences {
            rows.push(vec![d.address.to_string(), name.clone(), unit.clone(), show(left), show(right)]);
        }
    }
    output::table(&rows, ctx.style);
    let devices = diffs.iter().filter(|d| !d.differences.is_empty()).count();
    say!("{n} difference{} on {devices} device{}", plural(n), plural(devices));
}

fn plural(n: usize) -> &'static str {
    if n == 1 {
        ""
    } else {
        "s"
    }
}

fn diff(ctx: &Ctx, file: &Path, file2: Option<&Path>) -> anyhow::Result<()> {
    let left = read_file(file)?;
    let (right, right_name) = match file2 {
        Some(p) => (read_file(p)?, p.display().to_string()),
        None => (capture_like(&mut Live::new(ctx), &left)?, "live".to_string()),
    };
    let diffs = backup::diff(&left, &right);
    let differs = diffs.iter().any(|d| !d.differences.is_empty());
    let left_name = file.display().to_string();
    if ctx.json {
        output::json(&json!({"command": "diff", "left": left_name, "right": right_name, "differs": differs,
                             "devices": diff_json(&diffs)}));
    } else {
        print_diff(ctx, &diffs, &left_name, &right_name);
    }
    Ok(())
}

struct Options {
    dry_run: bool,
    skip_invalid: bool,
    to: Option<u8>,
    store: bool,
}

/// The file's devices with the address each is written to (`--to`).
fn targets(doc: &Document, to: Option<u8>) -> anyhow::Result<Vec<(Device, Address)>> {
    let Some(to) = to else { return Ok(doc.devices.iter().map(|d| (d.clone(), d.address())).collect()) };
    let [one] = &doc.devices[..] else {
        return Err(usage(format!(
            "--to names one device, but the file holds {}: take a backup of one device (backup -m ID)",
            doc.devices.len()
        )));
    };
    let mut at = one.address();
    match at.family {
        Family::PowerCube => {
            if ModuleId::new(to).is_none() {
                return Err(usage(format!("--to {to}: a PowerCube address is a {POWERCUBE_MODULE}")));
            }
            at.module = Some(to);
        }
        Family::Cdios => {
            if CdiosModule::new(to).is_none() {
                return Err(usage(format!("--to {to}: a Cdios address is a {CDIOS_MODULE}")));
            }
            at.module = Some(to);
        }
        f => return Err(usage(format!("--to is for PowerCube modules and Cdios modules, not the {f}"))),
    }
    Ok(vec![(one.clone(), at)])
}

fn invalid(path: &Path, problems: &[Problem], what: &str) -> anyhow::Error {
    usage(format!(
        "{} invalid value{} in {}; {what} (--skip-invalid writes the others):{}",
        problems.len(),
        plural(problems.len()),
        path.display(),
        problems_text(problems)
    ))
}

fn problems_text(problems: &[Problem]) -> String {
    problems.iter().map(|p| format!("\n  {p}")).collect()
}

fn restore(ctx: &Ctx, path: &Path, opts: Options) -> anyhow::Result<()> {
    let doc = read_file(path)?;
    let pairs = targets(&doc, opts.to)?;
    if opts.store && !pairs.iter().any(|(d, _)| d.family == Family::Cdios) {
        return Err(usage("--store stores a Cdios configuration, but the file holds no Cdios device"));
    }
    let mut problems: Vec<Problem> = pairs.iter().flat_map(|(d, _)| backup::check_file(d)).collect();
    // What the file alone shows is refused before the link opens.
    if !problems.is_empty() && !opts.skip_invalid {
        return Err(invalid(path, &problems, "nothing was sent"));
    }
    // From here a signal (an emergency halt from another terminal, Ctrl-C)
    // ends the restore after the value being written, with the report of
    // what was written and what was not.
    super::arm_interrupt()?;
    let mut live = Live::new(ctx);
    let mut devices = Vec::new();
    let mut mismatches = Vec::new();
    for (file_dev, at) in pairs {
        let now = live.capture(at)?;
        if opts.to.is_none() {
            let keys = backup::identity_mismatch(&file_dev, &now, backup::identity_keys(at.family));
            if !keys.is_empty() {
                mismatches.push(format!("\n  {at}: {}", keys.join(", ")));
            }
        }
        // The file's settings, addressed to the target, against the live ones.
        let mut wanted = file_dev.clone();
        (wanted.module, wanted.axis, wanted.node, wanted.link) = (at.module, at.axis, at.node, now.link.clone());
        problems.extend(live.check_live(&wanted, &now)?);
        devices.push((wanted, now));
    }
    output::forget_target();
    if !mismatches.is_empty() {
        return Err(usage(format!(
            "{} was taken from another device; nothing was written (name the target with --to ID to write it anyway):{}",
            path.display(),
            mismatches.concat()
        )));
    }
    let wrap = |ds: &[(Device, Device)], pick: fn(&(Device, Device)) -> &Device| Document {
        devices: ds.iter().map(pick).cloned().collect(),
        ..doc.clone()
    };
    let diffs = backup::diff(&wrap(&devices, |p| &p.0), &wrap(&devices, |p| &p.1));
    let differs = diffs.iter().any(|d| !d.differences.is_empty());
    if !ctx.json {
        print_diff(ctx, &diffs, &path.display().to_string(), "live");
    }
    if !problems.is_empty() && !opts.skip_invalid {
        return Err(invalid(path, &problems, "nothing was written"));
    }
    if !problems.is_empty() && !ctx.json {
        say!("skipping {} invalid value{}:{}", problems.len(), plural(problems.len()), problems_text(&problems));
    }
    let mut results: Vec<(Address, Vec<ValueResult>)> = Vec::new();
    // What ended the writes early: a device that refused or could not be
    // reached, or a signal. Every value not reached is reported as not written.
    let mut ended: Option<anyhow::Error> = None;
    if !opts.dry_run {
        // Only a signal: a closed output does not stop a restore (it says
        // less, but what it writes is the same).
        let signal = || supervisor::caught().map(stop_text);
        for (wanted, _) in &devices {
            if let Err(e) = live.ensure_at_rest(wanted.address()) {
                ended = Some(e);
                break;
            }
        }
        for (wanted, now) in &devices {
            let at = wanted.address();
            let skip: BTreeSet<String> = problems.iter().filter(|p| p.device == at).map(|p| p.name.clone()).collect();
            let why = match &ended {
                Some(e) => Some(format!("the restore stopped: {}", super::error_json::message(e))),
                None => signal(),
            };
            let rs = match why {
                Some(why) => backup::not_written(wanted, now, &skip, &why),
                None => live.restore(wanted, now, &skip, &signal).unwrap_or_else(|e| {
                    let why = format!("the restore stopped: {at}: {}", super::error_json::message(&e));
                    ended = Some(e);
                    backup::not_written(wanted, now, &skip, &why)
                }),
            };
            results.push((at, rs));
        }
        output::forget_target();
    }
    if let (None, Some(sig)) = (&ended, supervisor::caught()) {
        ended = Some(Interrupted(format!(": {}", stop_text(sig))).into());
    }
    let failed_any = results.iter().flat_map(|(_, rs)| rs).any(|r| r.outcome == backup::Outcome::Failed);
    // The EEPROM store is its own step, after every write went through.
    let mut stored: Vec<(Address, bool)> = Vec::new();
    let mut store_error = None;
    if opts.store && !opts.dry_run && !failed_any && ended.is_none() {
        for (wanted, _) in devices.iter().filter(|(d, _)| d.family == Family::Cdios) {
            let r = live.store(wanted.address());
            stored.push((wanted.address(), r.is_ok()));
            if let Err(e) = r {
                store_error.get_or_insert(e);
            }
        }
        output::forget_target();
    }
    let fails = store_error.is_some() || failed_any || ended.is_some();
    report(ctx, path, &opts, &devices, &diffs, differs, &problems, &results, &stored, fails)?;
    if let Some(e) = ended {
        return Err(e);
    }
    if let Some(e) = store_error {
        return Err(e.context("the EEPROM store (05h) failed"));
    }
    let failed: Vec<(Address, &ValueResult)> = results
        .iter()
        .flat_map(|(at, rs)| rs.iter().map(move |r| (*at, r)))
        .filter(|(_, r)| r.outcome == backup::Outcome::Failed)
        .collect();
    if let Some((_, first)) = failed.first() {
        let list: String = failed
            .iter()
            .map(|(at, r)| format!("\n  {at}: {}: {}", r.name, r.message.as_deref().unwrap_or("")))
            .collect();
        return Err(backup::Failed {
            kind: first.kind.unwrap_or(ErrorKind::Other),
            message: format!("{} value{} could not be restored:{list}", failed.len(), plural(failed.len())),
        }
        .into());
    }
    Ok(())
}

#[allow(clippy::too_many_arguments)]
fn report(
    ctx: &Ctx,
    path: &Path,
    opts: &Options,
    devices: &[(Device, Device)],
    diffs: &[backup::DeviceDiff],
    differs: bool,
    problems: &[Problem],
    results: &[(Address, Vec<ValueResult>)],
    stored: &[(Address, bool)],
    fails: bool,
) -> anyhow::Result<()> {
    let all = results.iter().flat_map(|(_, rs)| rs.iter());
    let summary = backup::summary(all);
    if ctx.json {
        let diff_objs = diff_json(diffs);
        let devs: Vec<Value> = devices
            .iter()
            .zip(diff_objs)
            .map(|((wanted, _), mut d)| {
                let rs = results.iter().find(|(at, _)| *at == wanted.address()).map_or(&[][..], |(_, r)| &r[..]);
                d["results"] = serde_json::to_value(rs).unwrap_or_default();
                if let Some((_, ok)) = stored.iter().find(|(at, _)| *at == wanted.address()) {
                    d["stored"] = (*ok).into();
                }
                d
            })
            .collect();
        let probs: Vec<Value> = problems
            .iter()
            .map(|p| {
                let mut o = envelope(p.device, &ctx.link_text);
                o.insert("name".into(), p.name.clone().into());
                o.insert("message".into(), p.message.clone().into());
                Value::Object(o)
            })
            .collect();
        let counts: serde_json::Map<String, Value> =
            summary.iter().map(|(o, n)| (o.name().to_string(), (*n).into())).collect();
        let doc = json!({"command": "restore", "file": path.display().to_string(), "dry_run": opts.dry_run,
                         "differs": differs, "problems": probs, "devices": devs, "summary": counts});
        // Stdout stays empty on a failure (the contract): what was written
        // goes with the error object instead.
        if fails {
            output::report_with_error(doc);
        } else {
            output::json(&doc);
        }
        return Ok(());
    }
    if opts.dry_run {
        say!("dry run: nothing was written{}", if opts.store { " or stored" } else { "" });
        return Ok(());
    }
    for (at, rs) in results {
        for r in rs.iter().filter(|r| r.outcome != backup::Outcome::Unchanged) {
            let unit = if r.unit.is_empty() { String::new() } else { format!(" {}", r.unit) };
            let mut line = format!(
                "{at}: {} = {}{unit}: {}",
                r.name,
                show(&Some(r.wanted.clone())),
                r.outcome.name().replace('_', " ")
            );
            match r.outcome {
                backup::Outcome::Clamped => {
                    line.push_str(&format!(" (the device holds {})", show(&Some(r.after.clone()))))
                }
                backup::Outcome::Written => line.push_str(&format!(" (was {})", show(&Some(r.before.clone())))),
                _ => line.push_str(&format!(" ({})", r.message.as_deref().unwrap_or(""))),
            }
            say!("{line}");
        }
    }
    let counts: Vec<String> = summary.iter().map(|(o, n)| format!("{n} {}", o.name().replace('_', " "))).collect();
    say!("restore: {}", counts.join(", "));
    for (at, ok) in stored {
        if *ok {
            say!("{at}: configuration stored in EEPROM (05h)");
        }
    }
    Ok(())
}
