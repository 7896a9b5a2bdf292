//! From a `--link` and a family to a ready link or session, written once for
//! the CLI, the dashboard, `monitor` and `sim`: the family's serial default,
//! the in-process bench behind `sim`, the `--log` traffic log and the
//! session options (`--timeout`, `--retries`, `--trace`).
//!
//! [`Opener::take_over`] opens for an emergency halt: a device held by
//! another axisctl process is released first (see [`crate::link::lock`]).
//!
//! It sits above [`crate::link`] and [`crate::sim`] (a `sim` link is a
//! client of the bench), so that neither of those imports the other.

use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, OnceLock};
use std::time::{Duration, Instant};

use crate::clock::Clock;
use crate::family::Family;
use crate::link::lock::{self, Found, Holder, TerminateError, Verdict};
use crate::link::log::{log_iface, LoggedByteLink, LoggedCanLink, TrafficLog};
use crate::link::{self, ByteLink, CanLink, LinkError, LinkSpec, SerialFormat, SimStart};
use crate::proto::pac::CheckRule;
use crate::session::cdios::Cdios;
use crate::session::pac::Pac;
use crate::session::powercube::PowerCube;
use crate::session::{RetryPolicy, TraceEvent};
use crate::sim::bench::{Bench, WireSpeed};

/// Why a link could not be opened for a family.
#[derive(Debug, thiserror::Error)]
pub enum OpenError {
    /// The family is not reached over this kind of link: bad input, nothing opened.
    #[error("{spec} is a CAN link; the {family} talks RS232 (serial:TTY or sim)")]
    NeedsRs232 { spec: LinkSpec, family: Family },
    #[error("{spec} is a serial link; {} (socketcan:, slcan:, socketcand: or sim)", needs_can(*.family))]
    NeedsCan { spec: LinkSpec, family: Option<Family> },
    /// `AXISCTL_SIM_WIRE_SPEED` does not parse: bad input.
    #[error("{0}")]
    WireSpeed(String),
    #[error(transparent)]
    Link(#[from] LinkError),
    /// The device is busy and its holder could not be made to let go.
    #[error("cannot open {path}: device busy, {why}")]
    Held { path: String, why: String },
}

fn needs_can(family: Option<Family>) -> String {
    match family {
        Some(f) => format!("the {f} is on CAN"),
        None => "this command needs CAN".into(),
    }
}

impl OpenError {
    /// True when the link given does not fit the family (a usage error).
    pub fn is_mismatch(&self) -> bool {
        !matches!(self, Self::Link(_) | Self::Held { .. })
    }

    /// The device path, when the open failed because another process holds it.
    pub fn busy_path(&self) -> Option<&str> {
        match self {
            Self::Link(LinkError::Open { path, source }) if source.kind() == std::io::ErrorKind::ResourceBusy => {
                Some(path)
            }
            _ => None,
        }
    }
}

/// How long the holder of a device has, once asked, to halt what it drives
/// and close the port. Its own halt is one round trip; the dashboard also
/// restores the terminal.
pub const RELEASE: Duration = Duration::from_secs(5);
/// How often the port is tried while its holder lets go.
const RELEASE_POLL: Duration = Duration::from_millis(20);

/// The axisctl process that held the device and was asked to let go.
#[derive(Debug, Clone)]
pub struct Takeover {
    /// The device path as given.
    pub path: String,
    pub holder: Holder,
    /// False when it had exited by itself before the signal went out.
    pub signalled: bool,
}

impl Takeover {
    /// Whether the holder has ended, waiting up to `within` for it: its port
    /// is closed before its process is gone. Asked after our own halt, so it
    /// never delays it.
    pub fn exited(&self, within: Duration) -> bool {
        self.holder.wait_gone(within)
    }
}

/// A serial line opened at the speed and format it runs at.
pub struct SerialLine {
    pub link: Box<dyn ByteLink>,
    pub baud: u32,
    pub format: SerialFormat,
}

/// A ready link: CAN frames or serial bytes, as the spec and family ask.
pub enum OpenedLink {
    Can(Box<dyn CanLink>),
    Serial(SerialLine),
}

/// What every session gets besides its link.
#[derive(Clone, Copy, Default)]
pub struct SessionOptions {
    /// `None`: the session's own default for its link.
    pub timeout: Option<Duration>,
    pub retry: RetryPolicy,
    /// Called with every frame sent and received (`--trace`).
    pub trace: Option<fn(TraceEvent)>,
    /// PA-CONTROL: CHECK including ETX.
    pub pac_check_etx: bool,
}

/// Applies the options every session takes. A macro because the three
/// sessions share the setters' names, not a trait.
macro_rules! configure {
    ($session:expr, $opts:expr) => {{
        let mut s = $session;
        let opts: &SessionOptions = $opts;
        if let Some(t) = opts.timeout {
            s.set_timeout(t);
        }
        s.set_retry(opts.retry);
        if let Some(trace) = opts.trace {
            s.set_tracer(Box::new(trace));
        }
        s
    }};
}

/// Opens links and sessions. Every `sim` link of one opener reaches the same bench.
pub struct Opener {
    clock: Arc<dyn Clock>,
    log: Option<PathBuf>,
    /// Read when a bench is built, so that a bad setting only matters to `sim`.
    wire: Result<Option<WireSpeed>, String>,
    bench: OnceLock<Bench>,
    /// Set by [`Self::keep_links_open`]: links stay open for the next session.
    keep: AtomicBool,
    kept: Mutex<Kept>,
}

impl Opener {
    pub fn new(clock: Arc<dyn Clock>) -> Self {
        Self {
            clock,
            log: None,
            wire: Ok(None),
            bench: OnceLock::new(),
            keep: AtomicBool::new(false),
            kept: Mutex::new(Kept::default()),
        }
    }

    /// From now on every link is opened once and kept for the opener's
    /// life: each later session on the same link shares it (`batch` and
    /// `shell` run many commands on one open link, without the adapter's
    /// handshake and the port lock each time). A one-shot command never
    /// calls it, so its link closes with its session as before.
    pub fn keep_links_open(&self) {
        self.keep.store(true, Ordering::SeqCst);
    }

    fn keeping(&self) -> bool {
        self.keep.load(Ordering::SeqCst)
    }

    /// An opener with the same clock, log and wire settings, for opening a
    /// lost link again from another thread (the dashboard's workers). Its
    /// `sim` links reach a bench of their own, not this one's.
    pub fn fresh(&self) -> Self {
        Self { log: self.log.clone(), wire: self.wire.clone(), ..Self::new(Arc::clone(&self.clock)) }
    }

    /// Appends the traffic of every link opened from now on to `path`.
    pub fn with_log(mut self, path: Option<PathBuf>) -> Self {
        self.log = path;
        self
    }

    /// Where `--log` appends the traffic, if anywhere.
    pub fn log_path(&self) -> Option<&std::path::Path> {
        self.log.as_deref()
    }

    /// Runs the `sim` bench at wire speed ([`WireSpeed::from_env`]).
    pub fn with_wire_speed(mut self, wire: Result<Option<WireSpeed>, String>) -> Self {
        self.wire = wire;
        self
    }

    pub fn clock(&self) -> &Arc<dyn Clock> {
        &self.clock
    }

    /// A bench of its own, at this opener's wire speed.
    pub fn new_bench(&self) -> Result<Bench, OpenError> {
        let wire = self.wire.clone().map_err(OpenError::WireSpeed)?;
        let mut bench = Bench::contract(Arc::clone(&self.clock));
        if wire.is_some() {
            crate::sim::serve::precise_timers();
        }
        bench.set_wire_speed(wire);
        Ok(bench)
    }

    /// The bench behind every `sim` link of this opener, built on first use.
    /// The first `sim` link's start state is the bench's: it is set up once.
    pub fn bench(&self, start: SimStart) -> Result<&Bench, OpenError> {
        if let Some(b) = self.bench.get() {
            return Ok(b);
        }
        let b = self.new_bench()?;
        b.start(self.clock.now(), start);
        Ok(self.bench.get_or_init(|| b))
    }

    /// Whether `family` talks CAN on `spec` (else it is a serial line;
    /// on `sim`, the bench's CAN bus or its PA-CONTROL line).
    pub fn is_can(spec: &LinkSpec, family: Family) -> bool {
        spec.is_can() && family.link_kind().can()
    }

    /// The link `family` talks over on `spec`.
    pub fn open(&self, spec: &LinkSpec, family: Family) -> Result<OpenedLink, OpenError> {
        if Self::is_can(spec, family) {
            Ok(OpenedLink::Can(self.can(spec, Some(family))?))
        } else {
            Ok(OpenedLink::Serial(self.serial(spec, family)?))
        }
    }

    /// A CAN link (for `family`, or for any family with `None`), logged with `--log`.
    pub fn can(&self, spec: &LinkSpec, family: Option<Family>) -> Result<Box<dyn CanLink>, OpenError> {
        if let LinkSpec::Serial { .. } = spec {
            return Err(OpenError::NeedsCan { spec: spec.clone(), family });
        }
        if !self.keeping() {
            return self.open_can(spec, family);
        }
        let key = spec.to_string();
        let mut kept = self.kept.lock().unwrap_or_else(|e| e.into_inner());
        if let Some((_, shared)) = kept.can.iter().find(|(k, _)| *k == key) {
            let shared = SharedCan(Arc::clone(shared));
            shared.drop_stale()?;
            return Ok(Box::new(shared));
        }
        let shared = Arc::new(Mutex::new(self.open_can(spec, family)?));
        kept.can.push((key, Arc::clone(&shared)));
        Ok(Box::new(SharedCan(shared)))
    }

    fn open_can(&self, spec: &LinkSpec, family: Option<Family>) -> Result<Box<dyn CanLink>, OpenError> {
        let l: Box<dyn CanLink> = match spec {
            LinkSpec::Sim(start) => Box::new(self.bench(*start)?.bus.open()),
            LinkSpec::Serial { .. } => return Err(OpenError::NeedsCan { spec: spec.clone(), family }),
            _ => link::open_can(spec)?,
        };
        Ok(match self.traffic_log(spec)? {
            Some(log) => Box::new(LoggedCanLink::new(l, log)),
            None => l,
        })
    }

    /// A serial line at the family's default speed and format unless the spec
    /// says otherwise; `sim` is the bench's PA-CONTROL line.
    pub fn serial(&self, spec: &LinkSpec, family: Family) -> Result<SerialLine, OpenError> {
        if !self.keeping() {
            return self.open_serial(spec, family);
        }
        let mut kept = self.kept.lock().unwrap_or_else(|e| e.into_inner());
        let key = format!("{spec} {family}");
        if let Some(k) = kept.serial.iter().find(|k| k.key == key) {
            let link = SharedBytes(Arc::clone(&k.link));
            let (baud, format) = (k.baud, k.format);
            link.drop_stale()?;
            return Ok(SerialLine { link: Box::new(link), baud, format });
        }
        // One port, one open: a family at another speed on the same port
        // (PowerCube RS232 after PA-CONTROL) closes the other first.
        kept.serial.retain(|k| !k.key.starts_with(&format!("{spec} ")));
        let line = self.open_serial(spec, family)?;
        let link = Arc::new(Mutex::new(line.link));
        kept.serial.push(KeptSerial { key, link: Arc::clone(&link), baud: line.baud, format: line.format });
        Ok(SerialLine { link: Box::new(SharedBytes(link)), baud: line.baud, format: line.format })
    }

    fn open_serial(&self, spec: &LinkSpec, family: Family) -> Result<SerialLine, OpenError> {
        let Some(default) = family.serial_default() else {
            return Err(OpenError::NeedsCan { spec: spec.clone(), family: Some(family) });
        };
        let (l, baud, format): (Box<dyn ByteLink>, _, _) = match spec {
            LinkSpec::Serial { path, baud, format } => {
                let (baud, format) = (baud.unwrap_or(default.baud), format.unwrap_or(default.format));
                (link::open_bytes(path, baud, format)?, baud, format)
            }
            LinkSpec::Sim(start) if family == Family::Pac => {
                (Box::new(self.bench(*start)?.pac_link(Arc::clone(&self.clock))), default.baud, default.format)
            }
            _ => return Err(OpenError::NeedsRs232 { spec: spec.clone(), family }),
        };
        let link = match self.traffic_log(spec)? {
            Some(log) => Box::new(LoggedByteLink::new(l, log)),
            None => l,
        };
        Ok(SerialLine { link, baud, format })
    }

    fn traffic_log(&self, spec: &LinkSpec) -> Result<Option<TrafficLog>, LinkError> {
        self.log.as_deref().map(|path| TrafficLog::append(path, &log_iface(spec))).transpose()
    }

    /// Runs `open`, and when it fails because another process holds the
    /// device: if the lock file names a live axisctl process (checked with the
    /// kernel, see [`Holder::check`]), sends it SIGTERM, on which it halts what
    /// it drives and exits, and runs `open` again until the port is free, for
    /// at most [`RELEASE`]. A holder that is not axisctl is never signalled.
    /// Opening is retried, never a motion: the caller sends its halt once open.
    ///
    /// Within that budget the lock is read again on every try, since the port
    /// and its lock do not change hands at once: a holder that has just opened
    /// has not written its lock yet, one that is closing has removed it, one
    /// that is exiting can no longer be checked, and a process that opened the
    /// port after the holder let go is asked in its turn. Another emergency
    /// halt holding the port is waited for, not signalled.
    pub fn take_over<T>(
        &self,
        mut open: impl FnMut(&Self) -> Result<T, OpenError>,
    ) -> Result<(T, Option<Takeover>), OpenError> {
        lock::taking_over();
        let err = match open(self) {
            Ok(t) => return Ok((t, None)),
            Err(e) => e,
        };
        let Some(path) = err.busy_path().map(str::to_string) else { return Err(err) };
        let held = |why: String| OpenError::Held { path: path.clone(), why };
        let deadline = Instant::now() + RELEASE;
        let mut asked = Asked::default();
        loop {
            let why = match asked.ask(&path) {
                Ok(why) => why,
                Err(why) => return Err(held(why)),
            };
            if Instant::now() >= deadline {
                return Err(held(why));
            }
            std::thread::sleep(RELEASE_POLL);
            match open(self) {
                Ok(t) => return Ok((t, asked.first)),
                Err(e) if e.busy_path().is_none() => return Err(e),
                Err(_) => {}
            }
        }
    }

    /// A PowerCube session: CAN, or RS232 on a `serial:` link.
    pub fn powercube(&self, spec: &LinkSpec, opts: &SessionOptions) -> Result<PowerCube, OpenError> {
        Ok(self.powercube_on(self.open(spec, Family::PowerCube)?, opts))
    }

    pub fn powercube_on(&self, link: OpenedLink, opts: &SessionOptions) -> PowerCube {
        let (pc, rtt) = match link {
            OpenedLink::Can(l) => {
                let rtt = l.round_trip();
                (PowerCube::over_can(l), rtt)
            }
            OpenedLink::Serial(s) => (PowerCube::over_rs232(s.link, s.baud), Duration::ZERO),
        };
        let mut pc = configure!(pc.with_clock(Arc::clone(&self.clock)), opts);
        // The timeout (default or --timeout) is the device's; the network's round trip comes on top.
        pc.set_timeout(pc.timeout() + rtt);
        pc
    }

    /// A PA-CONTROL session on a `serial:` line or the bench's (`sim`).
    pub fn pac(&self, spec: &LinkSpec, opts: &SessionOptions) -> Result<Pac, OpenError> {
        Ok(self.pac_on(self.serial(spec, Family::Pac)?, opts))
    }

    pub fn pac_on(&self, line: SerialLine, opts: &SessionOptions) -> Pac {
        let mut pac = configure!(Pac::new(line.link, line.baud, line.format).with_clock(Arc::clone(&self.clock)), opts);
        if opts.pac_check_etx {
            pac.set_check_rule(CheckRule::WithEtx);
        }
        pac
    }

    /// A Cdios session on a CAN link.
    pub fn cdios(&self, spec: &LinkSpec, opts: &SessionOptions) -> Result<Cdios, OpenError> {
        Ok(self.cdios_on(self.can(spec, Some(Family::Cdios))?, opts))
    }

    pub fn cdios_on(&self, link: Box<dyn CanLink>, opts: &SessionOptions) -> Cdios {
        let rtt = link.round_trip();
        let mut cd = configure!(Cdios::new(link).with_clock(Arc::clone(&self.clock)), opts);
        cd.set_timeout(cd.timeout() + rtt);
        cd
    }
}

/// The holders [`Opener::take_over`] has asked to let go of one device.
#[derive(Default)]
struct Asked {
    /// The first holder met, the one that was driving: the one reported.
    first: Option<Takeover>,
    /// Each signalled once: (PID, start time).
    signalled: Vec<(u32, u64)>,
}

impl Asked {
    /// Reads the lock of busy `path` and signals a new axisctl holder.
    /// `Ok`: worth trying the port again, and what to say if it stays busy;
    /// `Err`: it never will be ours (a holder that is not axisctl, a lock
    /// that does not parse, a refused signal), nothing more is tried.
    fn ask(&mut self, path: &str) -> Result<String, String> {
        let holder = match lock::find(path) {
            Found::Nothing => {
                return Ok("no axisctl lock names its holder (another program?); nothing was signalled".into())
            }
            Found::Unreadable(e) => return Err(format!("{e}: the holder is unknown, nothing was signalled")),
            Found::Holder(h, Verdict::Axisctl) => h,
            Found::Holder(h, Verdict::Stale) => {
                return Ok(format!(
                    "its lock names PID {}, which has exited: another program holds it; nothing was signalled",
                    h.pid
                ))
            }
            Found::Holder(h, Verdict::Unchecked(why)) => {
                return Ok(format!(
                    "its lock names PID {}, which could not be checked ({why}); it was not signalled",
                    h.pid
                ))
            }
            Found::Holder(h, Verdict::NotAxisctl(why)) => {
                return Err(format!("its lock names PID {}, which is not axisctl ({why}); it was not signalled", h.pid))
            }
        };
        let waited = |h: &Holder| {
            format!("held by axisctl {h}, which was sent SIGTERM but did not release it within {} s", RELEASE.as_secs())
        };
        if holder.halting {
            return Ok(format!(
                "held by axisctl {holder}, an emergency halt, which did not let go within {} s",
                RELEASE.as_secs()
            ));
        }
        if self.signalled.contains(&(holder.pid, holder.start)) {
            return Ok(waited(&holder));
        }
        let signalled = match holder.terminate() {
            Ok(()) => true,
            Err(TerminateError::Gone | TerminateError::Unchecked(_)) => false,
            Err(e) => return Err(format!("held by axisctl {holder}: {e}")),
        };
        if signalled {
            self.signalled.push((holder.pid, holder.start));
        }
        let why = if signalled {
            waited(&holder)
        } else {
            format!(
                "its lock names PID {}, which has exited: another program holds it; nothing was signalled",
                holder.pid
            )
        };
        self.first.get_or_insert(Takeover { path: path.into(), holder, signalled });
        Ok(why)
    }
}

/// The links an opener keeps open ([`Opener::keep_links_open`]), by link.
#[derive(Default)]
struct Kept {
    can: Vec<(String, KeptCan)>,
    serial: Vec<KeptSerial>,
}

type KeptCan = Arc<Mutex<Box<dyn CanLink>>>;

struct KeptSerial {
    /// The link and the family, whose default speed the line runs at.
    key: String,
    link: Arc<Mutex<Box<dyn ByteLink>>>,
    baud: u32,
    format: SerialFormat,
}

fn locked<T: ?Sized>(m: &Mutex<Box<T>>) -> std::sync::MutexGuard<'_, Box<T>> {
    m.lock().unwrap_or_else(|e| e.into_inner())
}

/// One session's handle on a kept CAN link.
struct SharedCan(Arc<Mutex<Box<dyn CanLink>>>);

impl SharedCan {
    /// Frames that arrived after the previous session ended (a late
    /// answer, another node's traffic) would be taken for answers to the
    /// next one's requests: a freshly opened link has none either.
    fn drop_stale(&self) -> Result<(), LinkError> {
        let mut l = locked(&self.0);
        while l.recv(Duration::ZERO)?.is_some() {}
        Ok(())
    }
}

impl CanLink for SharedCan {
    fn send(&mut self, frame: &crate::proto::CanFrame) -> Result<(), LinkError> {
        locked(&self.0).send(frame)
    }
    fn send_many(&mut self, frames: &[crate::proto::CanFrame]) -> Result<(), LinkError> {
        locked(&self.0).send_many(frames)
    }
    fn recv(&mut self, timeout: Duration) -> Result<Option<crate::proto::CanFrame>, LinkError> {
        locked(&self.0).recv(timeout)
    }
    fn round_trip(&self) -> Duration {
        locked(&self.0).round_trip()
    }
    fn stamp(&self) -> Option<Duration> {
        locked(&self.0).stamp()
    }
}

/// One session's handle on a kept serial line.
struct SharedBytes(Arc<Mutex<Box<dyn ByteLink>>>);

impl SharedBytes {
    fn drop_stale(&self) -> Result<(), LinkError> {
        locked(&self.0).clear_input()
    }
}

impl ByteLink for SharedBytes {
    fn write_all(&mut self, bytes: &[u8]) -> Result<(), LinkError> {
        locked(&self.0).write_all(bytes)
    }
    fn read(&mut self, buf: &mut [u8], timeout: Duration) -> Result<usize, LinkError> {
        locked(&self.0).read(buf, timeout)
    }
    fn clear_input(&mut self) -> Result<(), LinkError> {
        locked(&self.0).clear_input()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::clock::SystemClock;

    fn opener() -> Opener {
        Opener::new(Arc::new(SystemClock))
    }

    #[test]
    fn a_link_that_does_not_fit_the_family_is_a_mismatch() {
        let o = opener();
        let can: LinkSpec = "socketcan:axisnocan0".parse().unwrap();
        let serial: LinkSpec = "serial:/dev/axisctl-none".parse().unwrap();
        let e = o.open(&can, Family::Pac).err().unwrap();
        assert!(e.is_mismatch(), "{e}");
        assert_eq!(e.to_string(), "socketcan:axisnocan0 is a CAN link; the PA-CONTROL talks RS232 (serial:TTY or sim)");
        let e = o.open(&serial, Family::Cdios).err().unwrap();
        assert_eq!(
            e.to_string(),
            "serial:/dev/axisctl-none is a serial link; the Cdios is on CAN (socketcan:, slcan:, socketcand: or sim)"
        );
        let e = o.can(&serial, None).err().unwrap();
        assert!(e.to_string().ends_with("this command needs CAN (socketcan:, slcan:, socketcand: or sim)"), "{e}");
        assert!(!o.open(&serial, Family::PowerCube).err().unwrap().is_mismatch(), "a missing tty is a link error");
    }

    #[test]
    fn sim_links_share_one_bench_and_are_logged() {
        let dir = tempfile::tempdir().unwrap();
        let log = dir.path().join("traffic.log");
        let o = opener().with_log(Some(log.clone()));
        let mut can = o.can(&LinkSpec::Sim(Default::default()), Some(Family::PowerCube)).unwrap();
        can.send(&"0E3#0A27".parse().unwrap()).unwrap();
        let mut line = o.serial(&LinkSpec::Sim(Default::default()), Family::Pac).unwrap();
        assert_eq!((line.baud, line.format), (9600, SerialFormat::F7N1));
        line.link.write_all(b"\x020100\x03").unwrap();
        let text = std::fs::read_to_string(&log).unwrap();
        assert!(text.lines().any(|l| l.ends_with(" sim0 0E3#0A27")), "{text}");
        assert!(text.lines().any(|l| l.contains(") tx 02 ")), "{text}");
        assert!(std::ptr::eq(o.bench(SimStart::default()).unwrap(), o.bench(SimStart::default()).unwrap()));
    }
}
