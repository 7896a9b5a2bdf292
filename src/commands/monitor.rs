//! `axisctl monitor`: every frame on a CAN link (or in a candump log),
//! decoded, filtered, counted. Never sends anything.

use std::io::BufRead;
use std::io::Write;
use std::time::{Duration, SystemTime, UNIX_EPOCH};

use axisctl::bench::{Address, BenchLink, DeviceRef};
use axisctl::family::Family;
use std::io::IsTerminal;

use axisctl::monitor::{describe_event, passes_any, FamilyFilter, FrameInfo, IdFilter, Stats, Table};
use axisctl::proto::can_error::CanEvent;
use axisctl::proto::candump::{format_candump_error, format_candump_line, parse_candump_event};
use serde_json::json;

use super::{arm_interrupt, interrupted, usage, Ctx};
use crate::cli::monitor::Timestamps;
use crate::cli::MonitorArgs;

struct Filter {
    families: Vec<FamilyFilter>,
    modules: Vec<u8>,
    /// `-d`: the devices whose frames are shown.
    devices: Vec<Address>,
    ids: Vec<u32>,
    masks: Vec<IdFilter>,
}

impl Filter {
    fn new(a: &MonitorArgs, devices: Vec<Address>) -> anyhow::Result<Self> {
        let ids =
            a.id.iter()
                .map(|i| {
                    u32::from_str_radix(i.trim_start_matches("0x"), 16)
                        .ok()
                        .filter(|v| *v <= 0x1FFF_FFFF)
                        .ok_or_else(|| usage(format!("--id {i:?} is not a hex CAN id")))
                })
                .collect::<anyhow::Result<_>>()?;
        Ok(Self {
            families: a.family.clone(),
            modules: a.module.iter().flat_map(|l| l.0.iter().copied()).collect(),
            devices,
            ids,
            masks: a.filter.clone(),
        })
    }

    /// Error frames are the bus's, not an id's: only `--family` (as
    /// `other`) hides them, as candump shows them with the error mask
    /// `#FFFFFFFF` beside its id filters (compared in qemu: scripts/qemu-socketcan.sh).
    fn pass(&self, event: &CanEvent, i: &FrameInfo) -> bool {
        let family = self.families.is_empty() || self.families.iter().any(|f| f.pass(i));
        let CanEvent::Frame(f) = event else { return family };
        family
            && (self.modules.is_empty() || i.module.is_some_and(|m| self.modules.contains(&m)))
            && (self.devices.is_empty() || device_of(i).is_some_and(|d| self.devices.contains(&d)))
            && (self.ids.is_empty() || self.ids.contains(&f.id()))
            && passes_any(&self.masks, f)
    }
}

/// The one device a frame is of (`powercube:3`, `cdios:1/0`), by the ids
/// its family decoded; `None` for a broadcast, a frame of a whole node (NMT,
/// the controller's own) or of no known family.
fn device_of(i: &FrameInfo) -> Option<Address> {
    // A Cdios frame names its node and module, the others their module.
    let (first, second) = match i.node {
        Some(node) => (Some(node), Some(i.module?)),
        None => (i.module, None),
    };
    Address::of_ids(i.family?, first, second)
}

struct Printer<'a> {
    ctx: &'a Ctx,
    candump: bool,
    timestamps: Timestamps,
    /// The stamp of the first frame shown and of the one before, for `--timestamps zero|delta`.
    first: Option<f64>,
    last: Option<f64>,
    iface: String,
    /// The link listened on, for the envelope; `None` for a log replay.
    link: Option<&'a str>,
    /// `--table`: the rows instead of a line per frame.
    table: Option<Table>,
    terminal: bool,
    drawn: Option<std::time::Instant>,
    out: std::io::StdoutLock<'static>,
}

impl Printer<'_> {
    fn frame(&mut self, ts: f64, event: &CanEvent, i: &FrameInfo) -> std::io::Result<()> {
        let text = match event {
            CanEvent::Frame(f) => f.to_string(),
            CanEvent::Error(e) => e.to_string(),
        };
        if let Some(table) = &mut self.table {
            table.add(ts, event, i);
            return self.redraw(false);
        }
        if self.candump {
            let secs = ts.floor();
            let (s, us) = (secs as u64, ((ts - secs) * 1e6).round().min(999_999.0) as u32);
            let line = match event {
                CanEvent::Frame(f) => format_candump_line(s, us, &self.iface, f),
                CanEvent::Error(e) => format_candump_error(s, us, &self.iface, e),
            };
            writeln!(self.out, "{line}")?;
        } else if self.ctx.json {
            let mut v = serde_json::to_value(i).unwrap_or_default();
            // A frame that does not decode is no failure of the command:
            // `error` is kept for the error object (`jq -e .error`).
            if let Some(e) = v.as_object_mut().and_then(|o| o.remove("error")) {
                v["decode_error"] = e;
            }
            if let Some(link) = self.link {
                v["link"] = json!(link);
            }
            v["timestamp"] = json!(ts);
            v["frame"] = json!(text);
            writeln!(self.out, "{v}")?;
        } else {
            let who = match (i.family, i.node, i.module) {
                (Some(Family::Cdios), Some(n), Some(m)) => format!("node {n} module {m}"),
                (Some(Family::Cdios), Some(n), None) => format!("node {n}"),
                (_, _, Some(m)) => format!("module {m}"),
                _ => String::new(),
            };
            let fam = i.family.map_or("-", Family::name);
            let shown = match self.timestamps {
                Timestamps::Absolute => ts,
                Timestamps::Zero => ts - *self.first.get_or_insert(ts),
                Timestamps::Delta => ts - self.last.unwrap_or(ts),
            };
            self.last = Some(ts);
            let summary = text_of(self.ctx, i);
            writeln!(self.out, "{shown:17.6}  {text:<24} {fam:<9} {:<9} {who:<17} {summary}", i.kind)?;
        }
        self.out.flush()
    }

    /// `--table`: on a terminal the table is drawn again in place, at most
    /// [`TABLE_REDRAW`] apart; into a pipe or file it is printed once, at the end.
    fn redraw(&mut self, last: bool) -> std::io::Result<()> {
        let Some(table) = &self.table else { return Ok(()) };
        let due = self.drawn.is_none_or(|t| t.elapsed() >= TABLE_REDRAW);
        if !(last || self.terminal && due) {
            return Ok(());
        }
        if self.terminal {
            // Home and clear, as watch(1) does: the rows stay where the eye expects them.
            write!(self.out, "\x1b[H\x1b[2J")?;
        }
        for line in table.lines() {
            writeln!(self.out, "{line}")?;
        }
        self.drawn = Some(std::time::Instant::now());
        self.out.flush()
    }
}

/// How often the live table is drawn on a terminal.
const TABLE_REDRAW: Duration = Duration::from_millis(250);

/// The summary as the human line shows it: failures in the error colour.
fn text_of(ctx: &Ctx, i: &FrameInfo) -> String {
    match &i.error {
        Some(e) => ctx.style.error(&format!("{} ({e})", i.summary)),
        None if i.kind == "error" => ctx.style.error(&i.summary),
        None => i.summary.clone(),
    }
}

fn now_secs() -> f64 {
    SystemTime::now().duration_since(UNIX_EPOCH).map_or(0.0, |d| d.as_secs_f64())
}

pub fn run(ctx: &Ctx, a: &MonitorArgs) -> anyhow::Result<()> {
    if a.candump && ctx.json {
        return Err(usage("--candump and --json are two different outputs: pick one"));
    }
    if a.table && (a.candump || ctx.json) {
        return Err(usage("--table is a live view for a person: use it without --json and --candump"));
    }
    let (devices, on) = named(ctx, a)?;
    let filter = Filter::new(a, devices)?;
    let mut stats = Stats::default();
    let mut shown = 0u64;
    let limit = a.count.unwrap_or(u64::MAX);
    let given = match on {
        Some(l) => Some(&l.spec),
        None => ctx.given_link().ok().flatten(),
    };
    let iface = given.map_or_else(|| "can0".to_string(), axisctl::link::log::log_iface);
    let link = a.from_log.is_none().then_some(on.map_or(ctx.link_text.as_str(), |l| l.text.as_str()));
    let mut p = Printer {
        ctx,
        candump: a.candump,
        timestamps: a.timestamps,
        first: None,
        last: None,
        iface,
        link,
        table: a.table.then(Table::default),
        terminal: std::io::stdout().is_terminal(),
        drawn: None,
        out: std::io::stdout().lock(),
    };
    let mut handle = |ts: f64, event: &CanEvent, p: &mut Printer| -> anyhow::Result<bool> {
        let info = describe_event(event);
        if filter.pass(event, &info) {
            stats.add_event(event, &info);
            if let Err(e) = p.frame(ts, event, &info) {
                // Nothing more can be shown: the exit code follows the
                // failure's kind (a closed pipe is a normal end).
                crate::output::note_failure(&e);
                return Ok(false);
            }
            shown += 1;
        }
        Ok(shown < limit)
    };
    if let Some(path) = &a.from_log {
        // Streamed line by line (a log may be larger than memory; `-` is a
        // pipe from candump -L or a decompressor), each line bounded.
        let name = if path.as_os_str() == "-" { "standard input".to_string() } else { path.display().to_string() };
        let input: Box<dyn BufRead> = if path.as_os_str() == "-" {
            Box::new(std::io::stdin().lock())
        } else {
            let file = std::fs::File::open(path).map_err(|e| usage(format!("cannot read {name}: {e}")))?;
            Box::new(std::io::BufReader::new(file))
        };
        let mut lines = BoundedLines { input, line: Vec::new(), n: 0 };
        loop {
            let n = lines.n + 1;
            let Some(line) = lines.next_line().map_err(|e| usage(format!("{name}:{n}: {e}")))? else { break };
            if line.trim().is_empty() {
                continue;
            }
            let (ts, iface, event) = parse_candump_event(line).map_err(|e| usage(format!("{name}:{n}: {e}")))?;
            p.iface = iface;
            if !handle(ts, &event, &mut p)? {
                break;
            }
        }
    } else {
        let spec = match on {
            Some(l) => &l.spec,
            None => ctx.link()?,
        };
        if matches!(spec, axisctl::link::LinkSpec::Sim(_)) && !ctx.json {
            crate::output::err_line(format_args!(
                "axisctl: monitor: the in-process bench has no other client, so nothing will show; \
                 serve it with `axisctl sim` and monitor the link it prints (Ctrl-C ends)"
            ));
        }
        arm_interrupt()?;
        let mut link = ctx.opener().can(spec, None)?;
        // A listener shows the bus's error frames too (SocketCAN's error
        // filter; an slcan adapter's reports come anyway).
        link.report_errors();
        let start = std::time::Instant::now();
        let stop = a.duration.map(|s| Duration::from_secs_f64(s.max(0.0)));
        while !interrupted() && stop.is_none_or(|d| start.elapsed() < d) {
            if let Some(event) = link.recv_event(Duration::from_millis(50))? {
                // A remote daemon stamps frames when its bus received them;
                // the host's clock would add the network's delay.
                let at = link.stamp().map_or_else(now_secs, |d| d.as_secs_f64());
                if !handle(at, &event, &mut p)? {
                    break;
                }
            }
        }
    }
    if let Err(e) = p.redraw(true) {
        crate::output::note_failure(&e);
    }
    if a.stats && crate::output::failure().is_none() {
        let mut print = || -> std::io::Result<()> {
            if ctx.json {
                writeln!(p.out, "{}", json!({"stats": stats}))
            } else {
                writeln!(p.out, "{} frames, {} undecodable", stats.frames, stats.errors)?;
                stats.by_kind.iter().try_for_each(|(k, n)| writeln!(p.out, "  {k:<22} {n}"))
            }
        };
        if let Err(e) = print() {
            crate::output::note_failure(&e);
        }
    }
    Ok(())
}

/// `monitor -d`: the devices whose frames are shown and, listening live,
/// the link they are on (one CAN link of the bench, which may have several).
/// A PA-CONTROL device (RS232, no CAN frame), devices on two links or an
/// unknown name are usage errors before the link opens. Replaying a log,
/// an address needs no bench.
fn named<'c>(ctx: &'c Ctx, a: &MonitorArgs) -> anyhow::Result<(Vec<Address>, Option<&'c BenchLink>)> {
    if a.device.is_empty() {
        return Ok((Vec::new(), None));
    }
    let mut devices = Vec::new();
    for r in &a.device {
        let at = match r {
            DeviceRef::Address(at) => *at,
            DeviceRef::Name(_) => ctx.bench()?.resolve(r)?,
        };
        if !at.family().link_kind().can() {
            let named = if r.to_string() == at.to_string() { at.to_string() } else { format!("{r} ({at})") };
            return Err(usage(format!(
                "the monitor shows CAN frames; {named} is a {} device, which talks RS232 (--log on its commands \
                 records its traffic)",
                at.family()
            )));
        }
        devices.push(at);
    }
    if a.from_log.is_some() {
        return Ok((devices, None));
    }
    let named = super::devices::any_family(ctx, &a.device)?;
    let (first, on) = named[0];
    if let Some((at, l)) = named.iter().find(|(_, l)| l.text != on.text) {
        return Err(usage(format!(
            "{first} is on {} and {at} on {}: the monitor listens to one link; run one per link",
            on.text, l.text
        )));
    }
    Ok((devices, Some(on)))
}

/// The longest candump line: `(seconds.micros) iface ID#` and 8 data bytes
/// (64 for CAN FD) need far less; a longer one is no candump line.
const MAX_LOG_LINE: usize = 4096;

/// Lines of a candump log, each at most [`MAX_LOG_LINE`] bytes, counted.
struct BoundedLines {
    input: Box<dyn BufRead>,
    line: Vec<u8>,
    n: usize,
}

impl BoundedLines {
    fn next_line(&mut self) -> std::io::Result<Option<&str>> {
        use std::io::Read;
        self.line.clear();
        self.n += 1;
        let read = (&mut self.input).take(MAX_LOG_LINE as u64 + 1).read_until(b'\n', &mut self.line)?;
        if read == 0 {
            return Ok(None);
        }
        if self.line.len() > MAX_LOG_LINE {
            return Err(std::io::Error::other(format!("line longer than {MAX_LOG_LINE} bytes: not a candump log")));
        }
        std::str::from_utf8(&self.line)
            .map(|l| Some(l.trim_end_matches(['\n', '\r'])))
            .map_err(|_| std::io::Error::other("not text: not a candump log"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn device(frame: &str) -> Option<Address> {
        device_of(&axisctl::monitor::describe(&frame.parse().unwrap()))
    }

    #[test]
    fn a_frame_names_its_one_device() {
        assert_eq!(device("0F1#01"), Some(Address::PowerCube { module: 17 }), "a request");
        assert_eq!(device("0B1#0A2702000000"), Some(Address::PowerCube { module: 17 }), "its acknowledge");
        assert_eq!(device("201#2301008813000000"), Some(Address::Cdios { node: 1, module: 1 }));
        assert_eq!(device("100#0200"), None, "a broadcast is every module's");
        assert_eq!(device("000#0101"), None, "NMT is the bus's");
        assert_eq!(device("7FF#00"), None);
    }
}
