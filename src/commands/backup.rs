//! `axisctl backup`, `diff` and `restore`: thin adapters over
//! `axisctl::backup` (the document, the diff engine, the checks and the
//! write order live there), over every link of the bench and every family
//! on it.

pub(in crate::commands) mod live;

use std::collections::BTreeSet;
use std::path::Path;

use axisctl::backup::{self, Address, Device, Difference, Document, Problem, ValueResult};
use axisctl::bench::{self, Bench, BenchError, BenchLink, DeviceRef};
use axisctl::device::supervisor;
use axisctl::family::{Family, CDIOS_MODULE, POWERCUBE_MODULE};
use axisctl::link::LinkSpec;
use axisctl::session::ErrorKind;
use serde_json::{json, Value};

use super::{usage, Ctx, Interrupted, NoAnswer};
use crate::cli::backup::{BackupCommand, Selection};
use crate::cli::ids;
use crate::output::{self, say};
use live::{Live, Wanted};

pub fn run(ctx: &Ctx, cmd: BackupCommand) -> anyhow::Result<()> {
    match cmd {
        BackupCommand::Backup { select, out } => save(ctx, &select, out.as_deref()),
        BackupCommand::Diff { file, file2, device } => diff(ctx, &file, file2.as_deref(), &device),
        BackupCommand::Restore { file, dry_run, skip_invalid, to, store, device } => {
            restore(ctx, &file, Options { dry_run, skip_invalid, to, store }, &device)
        }
    }
}

/// The families a backup reads on the one `--link` of old: those named,
/// else every family the link carries (a serial line carries one, which
/// must be named).
fn families(link: &LinkSpec, named: &[Family]) -> anyhow::Result<Vec<Family>> {
    if let Some(f) = named.iter().find(|f| !bench::fits(link, **f)) {
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
    Ok(Family::ALL.into_iter().filter(|f| bench::fits(link, *f)).collect())
}

/// The (link, family) pairs a backup reads: on several links or a bench
/// file, every family of every link (those named only, if any are).
fn pairs<'b>(bench: &'b Bench, named: &[Family]) -> anyhow::Result<Vec<(&'b BenchLink, Family)>> {
    if bench.is_single() {
        let link = &bench.links()[0];
        return Ok(families(&link.spec, named)?.into_iter().map(|f| (link, f)).collect());
    }
    if let Some(f) = named.iter().find(|f| !bench.links().iter().any(|l| l.carries(**f))) {
        return Err(BenchError::NoLink { family: *f, links: bench.describe() }.into());
    }
    Ok(bench.pairs().filter(|(_, f)| named.is_empty() || named.contains(f)).collect())
}

/// The Cdios nodes a backup probes on `link`: `--node`, and on a bench
/// file every node it expects there.
fn nodes(bench: &Bench, link: &BenchLink, node: u8) -> Vec<u8> {
    if bench.is_single() {
        return vec![node];
    }
    let expected = link.devices.values().filter_map(|a| match a {
        bench::Address::Cdios { node, .. } => Some(*node),
        _ => None,
    });
    let all: BTreeSet<u8> = std::iter::once(node).chain(expected).collect();
    all.into_iter().collect()
}

/// Why the commands stop: a device a backup file names that is not on the
/// bench (no link reaches its family, or it does not answer).
struct Missing<'d> {
    device: &'d Device,
    error: anyhow::Error,
}

impl Missing<'_> {
    fn line(&self) -> String {
        format!("{} (on {}): {}", self.device.address(), self.device.link, super::error_json::message(&self.error))
    }

    fn json(&self) -> Value {
        let mut o = envelope(self.device.address(), &self.device.link);
        o.insert("error".into(), super::error_json::message(&self.error).into());
        Value::Object(o)
    }
}

/// The error of a command that met devices of a file missing from the
/// bench, every one named: exit 2 when the bench has no link for a family
/// of the file (what was given is short of the file), else 4 (no answer).
fn missing_error(path: &Path, mut missing: Vec<Missing>, what: &str) -> Option<anyhow::Error> {
    let lines: String = missing.iter().map(|m| format!("\n  {}", m.line())).collect();
    let n = missing.len();
    let no_link = missing.iter().position(|m| m.error.chain().any(|c| c.is::<BenchError>())).unwrap_or(0);
    let first = (n > 0).then(|| missing.swap_remove(no_link))?;
    Some(first.error.context(format!(
        "{n} device{} of {} {} not on the bench; {what}:{lines}",
        plural(n),
        path.display(),
        if n == 1 { "is" } else { "are" }
    )))
}

/// A device of a restore: the file's settings addressed to it, the live
/// device, and the link it is on.
type Pair<'a> = (Device, Device, &'a BenchLink);

/// Why the writes stop, as each value not written says it.
fn stop_text(sig: i32) -> String {
    format!("the restore stopped on {}", supervisor::signal_name(sig))
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

/// The devices of a backup by family (`--family`, `-m`, `--node`, or every
/// device of the bench), and the links they are on.
fn read_selection<'c>(ctx: &'c Ctx, select: &Selection) -> anyhow::Result<(Vec<Device>, Vec<&'c str>)> {
    // -m names PowerCube modules: alone, it selects them only.
    let named = if select.family.is_empty() && select.module.is_some() {
        vec![Family::PowerCube]
    } else {
        select.family.clone()
    };
    let bench = ctx.bench()?;
    let pairs = pairs(bench, &named)?;
    if select.module.is_some() && !pairs.iter().any(|(_, f)| *f == Family::PowerCube) {
        return Err(usage("-m names PowerCube modules, but the backup reads no PowerCube"));
    }
    let modules = match &select.module {
        Some(ids::Devices::One(id)) => Some(vec![*id]),
        Some(ids::Devices::List(list)) => Some(list.0.clone()),
        Some(ids::Devices::All) | None => None,
    };
    let mut live = Live::new(ctx);
    let mut links: Vec<&str> = Vec::new();
    let mut devices = Vec::new();
    for (link, family) in pairs {
        let wanted =
            Wanted { modules: modules.clone(), nodes: nodes(bench, link, select.node), named: !named.is_empty() };
        for at in live.present(link, family, &wanted)? {
            devices.push(live.capture(link, at)?);
        }
        if !links.contains(&link.text.as_str()) {
            links.push(&link.text);
        }
    }
    live::done();
    // A device the bench file expects is never silently left out of its backup.
    let expected = bench.links().iter().flat_map(|l| l.devices.iter().map(move |(n, a)| (n, Address::from(*a), l)));
    let absent: Vec<String> = expected
        .filter(|(_, a, _)| select.module.is_none() && (named.is_empty() || named.contains(&a.family)))
        .filter(|(_, a, l)| !devices.iter().any(|d: &Device| d.address() == *a && d.link == l.text))
        .map(|(n, a, l)| format!("{n} ({a} on {})", l.text))
        .collect();
    if !absent.is_empty() {
        return Err(
            NoAnswer(format!("expected but not answering: {}; no backup was written", absent.join(", "))).into()
        );
    }
    Ok((devices, links))
}

/// `backup -d`: exactly the devices named, in the order named, each read on
/// its own link. Each is first asked of its family as a whole backup asks
/// (the modules a Cdios node reports, the axes a PA-CONTROL has configured,
/// which also wants it in home position), so one that is not there is told
/// from one that fails. One that does not answer is named and nothing is
/// written (exit 4), as a device the bench file expects.
fn read_named<'c>(ctx: &'c Ctx, refs: &[DeviceRef]) -> anyhow::Result<(Vec<Device>, Vec<&'c str>)> {
    let named = super::devices::any_family(ctx, refs)?;
    let mut live = Live::new(ctx);
    let (mut links, mut devices, mut absent): (Vec<&str>, _, Vec<String>) = (Vec::new(), Vec::new(), Vec::new());
    for (at, link) in named {
        let one = Address::from(at);
        let (modules, nodes) = match at {
            bench::Address::PowerCube { module } => (Some(vec![module]), Vec::new()),
            bench::Address::Cdios { node, .. } => (None, vec![node]),
            bench::Address::Pac { .. } => (None, Vec::new()),
        };
        let wanted = Wanted { modules, nodes, named: true };
        let read = live.present(link, one.family, &wanted).and_then(|there| {
            if there.contains(&one) {
                live.capture(link, one)
            } else {
                Err(NoAnswer(format!("the {} reports no {at}", one.family)).into())
            }
        });
        match read {
            Ok(d) => devices.push(d),
            Err(e) if live::is_missing(&e) || e.is::<NoAnswer>() => {
                absent.push(format!("{at} (on {}): {}", link.text, super::error_json::message(&e)));
            }
            Err(e) => return Err(e),
        }
        if !links.contains(&link.text.as_str()) {
            links.push(&link.text);
        }
    }
    live::done();
    if !absent.is_empty() {
        return Err(NoAnswer(format!("named but not answering: {}; no backup was written", absent.join(", "))).into());
    }
    Ok((devices, links))
}

fn save(ctx: &Ctx, select: &Selection, out: Option<&Path>) -> anyhow::Result<()> {
    let (devices, links) =
        if select.device.is_empty() { read_selection(ctx, select)? } else { read_named(ctx, &select.device)? };
    let doc = Document {
        schema: backup::SCHEMA.into(),
        created_by: format!("axisctl {}", env!("AXISCTL_VERSION")),
        link: links.join(" "),
        devices,
    };
    let text = serde_json::to_string_pretty(&doc)?;
    // `--out -` is stdout, as no --out.
    let Some(path) = out.filter(|p| *p != Path::new("-")) else {
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

/// `diff -d` / `restore -d`: the devices of `doc` named, in the file's
/// order (a device on two links of the file: both). A device named that the
/// file does not hold is a usage error before anything opens. A bench-file
/// name needs the bench; an address does not (a diff of two files).
fn only_named(ctx: &Ctx, path: &Path, mut doc: Document, refs: &[DeviceRef]) -> anyhow::Result<Document> {
    if refs.is_empty() {
        return Ok(doc);
    }
    let mut wanted = Vec::new();
    for r in refs {
        let at = match r {
            DeviceRef::Address(a) => *a,
            DeviceRef::Name(_) => ctx.bench()?.resolve(r)?,
        };
        let one = Address::from(at);
        if !doc.devices.iter().any(|d| d.address() == one) {
            let held: Vec<String> = doc.devices.iter().map(|d| as_written(d.address())).collect();
            let named = if r.to_string() == at.to_string() { r.to_string() } else { format!("{r} ({at})") };
            return Err(usage(format!(
                "{named} is not a device of {}; nothing was sent (it holds {})",
                path.display(),
                if held.is_empty() { "none".into() } else { held.join(", ") }
            )));
        }
        wanted.push(one);
    }
    doc.devices.retain(|d| wanted.contains(&d.address()));
    Ok(doc)
}

/// A file's device as `-d` takes it (`powercube:3`), or in the file's own
/// terms when its ids are no device's (`powercube module 40`).
fn as_written(a: Address) -> String {
    let (first, second) = match a.family {
        Family::Cdios => (a.node, a.module),
        Family::Pac => (a.axis, None),
        Family::PowerCube => (a.module, None),
    };
    bench::Address::of_ids(a.family, first, second).map_or_else(|| a.to_string(), |one| one.to_string())
}

/// The live bench in the shape of `file`: each of its devices read at its
/// own address on the link that reaches it. A device not on the bench is
/// left out of the live side and listed; any other failure ends the diff.
fn capture_like<'d>(ctx: &Ctx, file: &'d Document) -> anyhow::Result<(Document, Vec<Missing<'d>>)> {
    let bench = ctx.bench()?;
    let mut live = Live::new(ctx);
    let (mut devices, mut missing) = (Vec::new(), Vec::new());
    for d in &file.devices {
        let read = live::link_of(bench, d).map_err(anyhow::Error::from).and_then(|l| live.capture(l, d.address()));
        match read {
            Ok(now) => devices.push(now),
            Err(error) if live::is_missing(&error) => missing.push(Missing { device: d, error }),
            Err(e) => return Err(e),
        }
    }
    live::done();
    let links: Vec<&str> = bench.links().iter().map(|l| l.text.as_str()).collect();
    Ok((Document { devices, link: links.join(" "), ..file.clone() }, missing))
}

/// `right` with only the devices `left` holds when `-d` cut `left` to the
/// devices named; whole otherwise (a device only in `right` is a difference).
fn keep_like(mut right: Document, left: &Document, named: &[DeviceRef]) -> Document {
    if !named.is_empty() {
        right.devices.retain(|d| left.devices.iter().any(|l| l.address() == d.address()));
    }
    right
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

fn diff(ctx: &Ctx, file: &Path, file2: Option<&Path>, named: &[DeviceRef]) -> anyhow::Result<()> {
    let left = only_named(ctx, file, read_file(file)?, named)?;
    let (right, right_name, missing) = match file2 {
        // The second file's devices of the same name: one it lacks shows as a difference.
        Some(p) => (keep_like(read_file(p)?, &left, named), p.display().to_string(), Vec::new()),
        None => {
            let (doc, missing) = capture_like(ctx, &left)?;
            (doc, "live".to_string(), missing)
        }
    };
    let mut diffs = backup::diff(&left, &right);
    // A device not on the bench is listed once, not as every one of its values.
    diffs.retain(|d| !missing.iter().any(|m| m.device.address() == d.address && m.device.link == d.link));
    let differs = diffs.iter().any(|d| !d.differences.is_empty());
    let left_name = file.display().to_string();
    if ctx.json {
        let absent: Vec<Value> = missing.iter().map(Missing::json).collect();
        let doc = json!({"command": "diff", "left": left_name, "right": right_name, "differs": differs,
                         "devices": diff_json(&diffs), "missing": absent});
        // Stdout stays empty on a failure (the contract): the diff goes with the error object.
        if missing.is_empty() {
            output::json(&doc);
        } else {
            output::report_with_error(doc);
        }
    } else {
        print_diff(ctx, &diffs, &left_name, &right_name);
        for m in &missing {
            say!("{}: not on the bench", m.line());
        }
    }
    match missing_error(file, missing, "the others were compared") {
        Some(e) => Err(e),
        None => Ok(()),
    }
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
            "--to names one device, but {} are to be restored: name one with -d, or take a backup of one device \
             (backup -d DEVICE)",
            doc.devices.len()
        )));
    };
    let mut at = one.address();
    match at.family {
        Family::PowerCube => {
            if !POWERCUBE_MODULE.contains(to) {
                return Err(usage(format!("--to {to}: a PowerCube address is a {POWERCUBE_MODULE}")));
            }
            at.module = Some(to);
        }
        Family::Cdios => {
            if !CDIOS_MODULE.contains(to) {
                return Err(usage(format!("--to {to}: a Cdios address is a {CDIOS_MODULE}")));
            }
            at.module = Some(to);
        }
        f => return Err(usage(format!("--to is for PowerCube modules and Cdios modules, not the {f}"))),
    }
    Ok(vec![(one.clone(), at)])
}

/// The invalid values of a restore, each with the index of its device in
/// the file (two links may each have a module 3).
type Problems = Vec<(usize, Problem)>;

fn invalid(path: &Path, problems: &Problems, what: &str) -> anyhow::Error {
    usage(format!(
        "{} invalid value{} in {}; {what} (--skip-invalid writes the others):{}",
        problems.len(),
        plural(problems.len()),
        path.display(),
        problems_text(problems)
    ))
}

fn problems_text(problems: &Problems) -> String {
    problems.iter().map(|(_, p)| format!("\n  {p}")).collect()
}

fn restore(ctx: &Ctx, path: &Path, opts: Options, named: &[DeviceRef]) -> anyhow::Result<()> {
    let doc = only_named(ctx, path, read_file(path)?, named)?;
    let pairs = targets(&doc, opts.to)?;
    if opts.store && !pairs.iter().any(|(d, _)| d.family == Family::Cdios) {
        return Err(usage("--store stores a Cdios configuration, but the file holds no Cdios device"));
    }
    let mut problems: Problems = pairs
        .iter()
        .enumerate()
        .flat_map(|(i, (d, _))| backup::check_file(d).into_iter().map(move |p| (i, p)))
        .collect();
    // What the file alone shows is refused before the link opens.
    if !problems.is_empty() && !opts.skip_invalid {
        return Err(invalid(path, &problems, "nothing was sent"));
    }
    // From here a signal (an emergency halt from another terminal, Ctrl-C)
    // ends the restore after the value being written, with the report of
    // what was written and what was not.
    super::arm_interrupt()?;
    let bench = ctx.bench()?;
    let mut live = Live::new(ctx);
    let mut devices = Vec::new();
    let mut mismatches = Vec::new();
    let mut missing = Vec::new();
    for (file_dev, at) in &pairs {
        let at = *at;
        let link = match live::link_of(bench, file_dev) {
            Ok(l) => l,
            Err(e) => {
                missing.push(Missing { device: file_dev, error: e.into() });
                continue;
            }
        };
        let now = match live.capture(link, at) {
            Ok(now) => now,
            Err(error) if live::is_missing(&error) => {
                missing.push(Missing { device: file_dev, error });
                continue;
            }
            Err(e) => return Err(e),
        };
        if opts.to.is_none() {
            let keys = backup::identity_mismatch(file_dev, &now, backup::identity_keys(at.family));
            if !keys.is_empty() {
                mismatches.push(format!("\n  {at}: {}", keys.join(", ")));
            }
        }
        // The file's settings, addressed to the target, against the live ones.
        let mut wanted = file_dev.clone();
        (wanted.module, wanted.axis, wanted.node, wanted.link) = (at.module, at.axis, at.node, now.link.clone());
        problems.extend(live.check_live(link, &wanted, &now)?.into_iter().map(|p| (devices.len(), p)));
        devices.push((wanted, now, link));
    }
    live::done();
    // Every device of the file is written, or none: one not on the bench stops it here.
    if let Some(e) = missing_error(path, missing, "nothing was written") {
        return Err(e);
    }
    if !mismatches.is_empty() {
        return Err(usage(format!(
            "{} was taken from another device; nothing was written (name the target with --to ID to write it anyway):{}",
            path.display(),
            mismatches.concat()
        )));
    }
    let side = |file: bool| Document {
        devices: devices.iter().map(|(w, n, _)| if file { w } else { n }).cloned().collect(),
        ..doc.clone()
    };
    let diffs = backup::diff(&side(true), &side(false));
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
    let mut results: Vec<(usize, Vec<ValueResult>)> = Vec::new();
    // What ended the writes early: a device that refused or could not be
    // reached, or a signal. Every value not reached is reported as not written.
    let mut ended: Option<anyhow::Error> = None;
    if !opts.dry_run {
        // Only a signal: a closed output does not stop a restore (it says
        // less, but what it writes is the same).
        let signal = || supervisor::caught().map(stop_text);
        for (wanted, _, link) in &devices {
            if let Err(e) = live.ensure_at_rest(link, wanted.address()) {
                ended = Some(e);
                break;
            }
        }
        for (i, (wanted, now, link)) in devices.iter().enumerate() {
            let at = wanted.address();
            let skip: BTreeSet<String> =
                problems.iter().filter(|(d, _)| *d == i).map(|(_, p)| p.name.clone()).collect();
            let why = match &ended {
                Some(e) => Some(format!("the restore stopped: {}", super::error_json::message(e))),
                None => signal(),
            };
            let rs = match why {
                Some(why) => backup::not_written(wanted, now, &skip, &why),
                None => live.restore(link, wanted, now, &skip, &signal).unwrap_or_else(|e| {
                    let why = format!("the restore stopped: {at}: {}", super::error_json::message(&e));
                    ended = Some(e);
                    backup::not_written(wanted, now, &skip, &why)
                }),
            };
            results.push((i, rs));
        }
        live::done();
    }
    if let (None, Some(sig)) = (&ended, supervisor::caught()) {
        ended = Some(Interrupted(format!(": {}", stop_text(sig))).into());
    }
    let failed_any = results.iter().flat_map(|(_, rs)| rs).any(|r| r.outcome == backup::Outcome::Failed);
    // The EEPROM store is its own step, after every write went through.
    let mut stored: Vec<(usize, bool)> = Vec::new();
    let mut store_error = None;
    if opts.store && !opts.dry_run && !failed_any && ended.is_none() {
        for (i, (wanted, _, link)) in devices.iter().enumerate().filter(|(_, (d, _, _))| d.family == Family::Cdios) {
            let r = live.store(link, wanted.address());
            stored.push((i, r.is_ok()));
            if let Err(e) = r {
                store_error.get_or_insert(e);
            }
        }
        live::done();
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
        .flat_map(|(i, rs)| {
            let at = devices[*i].0.address();
            rs.iter().map(move |r| (at, r))
        })
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
    devices: &[Pair],
    diffs: &[backup::DeviceDiff],
    differs: bool,
    problems: &Problems,
    results: &[(usize, Vec<ValueResult>)],
    stored: &[(usize, bool)],
    fails: bool,
) -> anyhow::Result<()> {
    let all = results.iter().flat_map(|(_, rs)| rs.iter());
    let summary = backup::summary(all);
    if ctx.json {
        let diff_objs = diff_json(diffs);
        let devs: Vec<Value> = devices
            .iter()
            .zip(diff_objs)
            .enumerate()
            .map(|(i, (_, mut d))| {
                let rs = results.iter().find(|(at, _)| *at == i).map_or(&[][..], |(_, r)| &r[..]);
                d["results"] = serde_json::to_value(rs).unwrap_or_default();
                if let Some((_, ok)) = stored.iter().find(|(at, _)| *at == i) {
                    d["stored"] = (*ok).into();
                }
                d
            })
            .collect();
        let probs: Vec<Value> = problems
            .iter()
            .map(|(i, p)| {
                let link = devices.get(*i).map_or("", |(w, _, _)| w.link.as_str());
                let mut o = envelope(p.device, link);
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
    // Two links may each have a module 3: a bench of several links says which.
    let several = devices.iter().any(|(d, _, _)| devices[0].0.link != d.link);
    let name = |i: usize| {
        let (d, _, _) = &devices[i];
        if several {
            format!("{} on {}", d.address(), d.link)
        } else {
            d.address().to_string()
        }
    };
    for (i, rs) in results {
        let at = name(*i);
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
    for (i, ok) in stored {
        if *ok {
            say!("{}: configuration stored in EEPROM (05h)", name(*i));
        }
    }
    Ok(())
}
