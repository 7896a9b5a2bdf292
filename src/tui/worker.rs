//! One worker per link: a thread that owns the link's device sources,
//! polls every device round after round at the wanted rate, and carries
//! out actions between two polls, so an action waits at most for one
//! device poll. A halt-all goes before anything else queued. Motion actions
//! are sent once: the sessions never retry them, and neither does the worker.
//!
//! The rate adapts to what the link can carry: a round that takes longer
//! than the wanted period is followed at once by the next, so the achieved
//! rate is what the link gives, and the [`LinkEvent::Cycle`] reports say
//! which it is.
//!
//! A link that stops answering altogether ([`DOWN_AFTER`] rounds in which
//! no device answered) and that the worker knows how to open again
//! ([`Reopen`]) is closed, which releases the device file so a replugged
//! adapter comes back under the same name, and reopened from the same path
//! with a backoff from [`BACKOFF_MIN`] to [`BACKOFF_MAX`]; its devices are
//! then discovered again. [`ToWorker::Rescan`] discovers again on demand.
//!
//! A worker that panics first halts what it set moving (home, jog, go to)
//! with the sources it still holds, then reports the panic, and the UI
//! halts what the dashboard moved on the other links and quits: a panic
//! never leaves an axis moving with nobody watching it.

use crate::address::Address;
use crate::device::face::MotionTarget;
use std::sync::mpsc::{Receiver, RecvTimeoutError, Sender, TryRecvError};
use std::sync::Arc;
use std::time::{Duration, Instant};

use super::event::{Event, LinkEvent, LinkId, ToWorker};
use super::source::{DeviceSource, Health};
use crate::clock::Clock;

/// Opens the link again from the same path, with fresh device sources.
pub type Reopen = Box<dyn FnMut() -> Result<Vec<Box<dyn DeviceSource>>, String> + Send>;

/// Rounds in a row in which no device answered before the link counts as lost.
pub const DOWN_AFTER: u32 = 3;
/// First wait before reopening a lost link; it doubles up to [`BACKOFF_MAX`].
pub const BACKOFF_MIN: Duration = Duration::from_millis(500);
pub const BACKOFF_MAX: Duration = Duration::from_secs(8);

/// A lost link waiting to be reopened.
#[derive(Debug, Clone, Copy)]
struct Down {
    next_try: Instant,
    backoff: Duration,
}

/// Slowest and fastest poll rates the dashboard asks for.
pub const MIN_RATE: f64 = 0.5;
pub const MAX_RATE: f64 = 100.0;

pub struct LinkWorker {
    link: LinkId,
    sources: Vec<Box<dyn DeviceSource>>,
    /// (source index, device), in display order.
    devices: Vec<(usize, Address)>,
    clock: Arc<dyn Clock>,
    rate: f64,
    last_round: Option<Instant>,
    reopen: Option<Reopen>,
    /// Rounds in a row in which no device answered.
    silent_rounds: u32,
    down: Option<Down>,
    /// The devices polled when the link was lost: polled again after the
    /// reopen even if the scan misses them (a module still powering up).
    lost: Vec<Address>,
    /// Devices this worker sent a motion to (acknowledged or not: a lost
    /// acknowledge may hide a taken motion), halted if the worker panics.
    moved: Vec<Address>,
}

impl LinkWorker {
    pub fn new(link: LinkId, sources: Vec<Box<dyn DeviceSource>>, clock: Arc<dyn Clock>, rate: f64) -> Self {
        Self {
            link,
            sources,
            devices: Vec::new(),
            clock,
            rate: rate.clamp(MIN_RATE, MAX_RATE),
            last_round: None,
            reopen: None,
            silent_rounds: 0,
            down: None,
            lost: Vec::new(),
            moved: Vec::new(),
        }
    }

    /// Lets the worker close and reopen the link when it stops answering.
    pub fn with_reopen(mut self, reopen: Reopen) -> Self {
        self.reopen = Some(reopen);
        self
    }

    /// The link was lost and is not open again yet.
    pub fn is_down(&self) -> bool {
        self.down.is_some()
    }

    /// Counts a round; after [`DOWN_AFTER`] silent ones, closes the link (the
    /// sources own it: dropping them releases the device) and plans a reopen.
    fn after_round(&mut self, answered: bool, out: &mut dyn FnMut(LinkEvent)) {
        if answered || self.devices.is_empty() || self.reopen.is_none() {
            self.silent_rounds = 0;
            return;
        }
        self.silent_rounds += 1;
        if self.silent_rounds < DOWN_AFTER {
            return;
        }
        self.silent_rounds = 0;
        self.sources.clear();
        self.lost = self.devices.drain(..).map(|d| d.1).collect();
        self.down = Some(Down { next_try: self.clock.now() + BACKOFF_MIN, backoff: BACKOFF_MIN });
        out(LinkEvent::Down { link: self.link, why: format!("no device answered for {DOWN_AFTER} rounds") });
    }

    /// A lost link whose backoff is over: one try to open it again.
    fn try_reopen(&mut self, out: &mut dyn FnMut(LinkEvent)) {
        let (Some(down), Some(reopen)) = (self.down, self.reopen.as_mut()) else { return };
        let now = self.clock.now();
        if now < down.next_try {
            return;
        }
        match reopen() {
            Ok(sources) => {
                self.sources = sources;
                self.down = None;
                out(LinkEvent::Reopened { link: self.link });
                let mut ev = self.discover();
                for key in std::mem::take(&mut self.lost) {
                    let source = self.sources.iter().position(|s| s.family() == key.family());
                    if let (Some(i), false) = (source, self.devices.iter().any(|d| d.1 == key)) {
                        self.devices.push((i, key));
                    }
                }
                if let LinkEvent::Discovered { devices, .. } = &mut ev {
                    *devices = self.devices.iter().map(|d| d.1).collect();
                }
                out(ev);
            }
            Err(why) => {
                let backoff = (down.backoff * 2).min(BACKOFF_MAX);
                self.down = Some(Down { next_try: now + backoff, backoff });
                out(LinkEvent::Down { link: self.link, why: format!("reopening failed: {why}") });
            }
        }
    }

    pub fn rate(&self) -> f64 {
        self.rate
    }

    /// Asks every source for its devices.
    pub fn discover(&mut self) -> LinkEvent {
        let mut errors = Vec::new();
        self.devices.clear();
        for (i, s) in self.sources.iter_mut().enumerate() {
            match s.discover() {
                Ok(list) => self.devices.extend(list.into_iter().map(|d| (i, d))),
                Err(e) => errors.push(format!("{} scan failed: {e}", s.family().display_name())),
            }
        }
        LinkEvent::Discovered { link: self.link, devices: self.devices.iter().map(|d| d.1).collect(), errors }
    }

    /// Carries out queued requests, a halt-all first. Returns `true` on Quit.
    pub fn handle(&mut self, mut msgs: Vec<ToWorker>, out: &mut dyn FnMut(LinkEvent)) -> bool {
        if msgs.contains(&ToWorker::HaltAll) {
            msgs.retain(|m| *m != ToWorker::HaltAll);
            self.halt_all(out);
        }
        for m in msgs {
            match m {
                ToWorker::Quit => return true,
                ToWorker::SetRate(r) => self.rate = r.clamp(MIN_RATE, MAX_RATE),
                ToWorker::Rescan if self.down.is_some() => {}
                ToWorker::Rescan => out(self.discover()),
                ToWorker::HaltAll => unreachable!("handled first"),
                ToWorker::Act(dev, action) => {
                    if action.is_motion() && !self.moved.contains(&dev) {
                        self.moved.push(dev);
                    }
                    let what = action.name();
                    let result = match self.source_of(dev) {
                        Some(i) => self.sources[i].act(dev, action).map_err(|e| e.to_string()),
                        None => Err(format!("{} is not on this link", dev.label())),
                    };
                    out(LinkEvent::Acted { link: self.link, device: Some(dev), what, at: self.clock.now(), result });
                }
            }
        }
        false
    }

    fn source_of(&self, dev: Address) -> Option<usize> {
        self.devices
            .iter()
            .find(|(_, d)| *d == dev)
            .map(|(i, _)| *i)
            .or_else(|| self.sources.iter().position(|s| s.family() == dev.family()))
    }

    fn halt_all(&mut self, out: &mut dyn FnMut(LinkEvent)) {
        for s in &mut self.sources {
            for (device, r) in s.halt_all() {
                let at = self.clock.now();
                out(LinkEvent::Acted {
                    link: self.link,
                    device,
                    what: "HALT ALL".into(),
                    at,
                    result: r.map_err(|e| e.to_string()),
                });
            }
        }
    }

    /// Polls the `i`th device.
    pub fn poll_device(&mut self, i: usize) -> LinkEvent {
        let (s, device) = self.devices[i];
        let result = self.sources[s].poll(device);
        let health = match &result {
            Ok(_) => Health::Answer,
            Err(e) => e.health(),
        };
        LinkEvent::Polled {
            link: self.link,
            device,
            at: self.clock.now(),
            result: result.map_err(|e| e.to_string()),
            health,
        }
    }

    /// One round over every device, taking queued requests between polls
    /// from `pending`. Returns `true` on Quit.
    pub fn round(&mut self, pending: &mut dyn FnMut() -> Vec<ToWorker>, out: &mut dyn FnMut(LinkEvent)) -> bool {
        let start = self.clock.now();
        let period = self.last_round.map_or(Duration::ZERO, |l| start - l);
        self.last_round = Some(start);
        if self.down.is_some() {
            self.try_reopen(out);
        }
        let mut answered = false;
        for i in 0..self.devices.len() {
            if self.handle(pending(), out) {
                return true;
            }
            // The device's reads and the next device's go out before this
            // poll waits: the link carries the next device's while this
            // one's answers come back (sources that cannot, send on poll).
            let n = self.devices.len();
            for &(s, dev) in &self.devices[i.min(n)..(i + 2).min(n)] {
                self.sources[s].poll_ahead(dev);
            }
            let ev = self.poll_device(i);
            answered |= matches!(ev, LinkEvent::Polled { health: Health::Answer, .. });
            out(ev);
        }
        if self.handle(pending(), out) {
            return true;
        }
        if self.down.is_none() {
            self.after_round(answered, out);
        }
        out(LinkEvent::Cycle { link: self.link, busy: self.clock.now() - start, period });
        false
    }

    /// Devices this worker sent a motion to.
    pub fn moved(&self) -> &[Address] {
        &self.moved
    }

    /// Halts every device this worker sent a motion to, each on its own (a
    /// source that panics again is skipped). Returns what the event pane and
    /// the exit message say, e.g. `halted PowerCube 3` or `HALT OF ... FAILED`.
    pub fn halt_moved(&mut self) -> String {
        let mut said = Vec::new();
        for dev in self.moved.clone() {
            // The face's halt, the one every way out of a motion uses.
            let halted = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                match (self.source_of(dev), MotionTarget::try_from(dev).ok()) {
                    (Some(i), Some(at)) => self.sources[i].face().halt(at, 1).map(|_| ()).map_err(|e| e.to_string()),
                    (Some(_), None) => Err("no such device".into()),
                    (None, _) => Err("its link is closed".into()),
                }
            }));
            said.push(match halted {
                Ok(Ok(_)) => format!("halted {}", dev.label()),
                Ok(Err(e)) => format!("HALT OF {} FAILED: {e}", dev.label()),
                Err(_) => format!("HALT OF {} FAILED: panicked", dev.label()),
            });
        }
        if said.is_empty() {
            "nothing it moved".into()
        } else {
            said.join(", ")
        }
    }

    /// The thread body: discover, then rounds until Quit or the UI is gone.
    /// A panic halts what this worker moved before it is reported (as
    /// [`LinkEvent::Ended`], and [`Event::Stop`] for the UI to halt the rest).
    pub fn run(mut self, rx: Receiver<ToWorker>, tx: Sender<Event>) {
        let served = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| self.serve(&rx, &tx)));
        if let Err(payload) = served {
            let why = panic_text(payload.as_ref());
            let halted = self.halt_moved();
            let link = self.link;
            let _ = tx.send(Event::Link(LinkEvent::Ended { link, why: format!("worker panicked: {why} ({halted})") }));
            let _ = tx.send(Event::Stop(format!("the worker of link {link} panicked ({why}; {halted})")));
        }
    }

    fn serve(&mut self, rx: &Receiver<ToWorker>, tx: &Sender<Event>) {
        let send = |ev: LinkEvent| tx.send(Event::Link(ev)).is_ok();
        if !send(self.discover()) {
            return;
        }
        let mut gone = false;
        loop {
            let mut pending = || {
                let mut v = Vec::new();
                loop {
                    match rx.try_recv() {
                        Ok(m) => v.push(m),
                        Err(TryRecvError::Empty) => break,
                        Err(TryRecvError::Disconnected) => {
                            v.push(ToWorker::Quit);
                            break;
                        }
                    }
                }
                v
            };
            let start = self.clock.now();
            if self.round(&mut pending, &mut |ev| gone |= !send(ev)) || gone {
                return;
            }
            // Wait out the rest of the period, but take requests at once.
            let deadline = start + Duration::from_secs_f64(1.0 / self.rate);
            loop {
                let now = self.clock.now();
                if now >= deadline {
                    break;
                }
                match rx.recv_timeout(deadline - now) {
                    Ok(m) => {
                        let mut msgs = vec![m];
                        msgs.extend(rx.try_iter());
                        if self.handle(msgs, &mut |ev| gone |= !send(ev)) || gone {
                            return;
                        }
                    }
                    Err(RecvTimeoutError::Timeout) => break,
                    Err(RecvTimeoutError::Disconnected) => return,
                }
            }
        }
    }
}

/// A panic's message.
pub fn panic_text(payload: &(dyn std::any::Any + Send)) -> String {
    payload
        .downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| payload.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "panic".into())
}

/// Starts a worker thread; a panic in it is reported as [`LinkEvent::Ended`].
pub fn spawn(worker: LinkWorker, tx: Sender<Event>) -> (Sender<ToWorker>, std::thread::JoinHandle<()>) {
    let (wtx, wrx) = std::sync::mpsc::channel();
    let link = worker.link;
    let handle = std::thread::Builder::new()
        .name(format!("axisctl-link-{link}"))
        .spawn(move || {
            let tx2 = tx.clone();
            let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(move || worker.run(wrx, tx)));
            if let Err(p) = r {
                let why = panic_text(p.as_ref());
                let _ = tx2.send(Event::Link(LinkEvent::Ended { link, why: format!("worker panicked: {why}") }));
            }
        })
        .expect("spawn a link worker thread");
    (wtx, handle)
}
