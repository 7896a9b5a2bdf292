//! The dashboard's state, and what keys and worker reports do to it. Pure:
//! no I/O, no clock (time arrives with [`Event::Tick`] and in the reports),
//! so tests drive it event by event.

use crate::address::Address;
use crate::device::face::MotionTarget;
use std::collections::{HashMap, VecDeque};
use std::time::{Duration, Instant};

use crossterm::event::{KeyCode, KeyEvent, KeyEventKind};

use super::event::{Event, LinkEvent, LinkId, ToWorker};
use super::history::{self, History, Trace};
use super::keys::{self, KeyAction};
use super::source::{Action, Health, Snapshot};
use crate::family::Family;

/// How long a changed value stays highlighted.
pub const HIGHLIGHT: Duration = Duration::from_millis(1500);
/// Events kept in the event pane.
pub const EVENT_LINES: usize = 500;
/// Poll rates `<` and `>` step through, Hz.
pub const RATES: &[f64] = &[1.0, 2.0, 5.0, 10.0, 20.0, 50.0];

/// Jog steps per family, in the device's units, smallest first.
pub fn jog_steps(family: Family) -> &'static [f64] {
    match family {
        Family::PowerCube => &[0.001, 0.01, 0.1, 0.5],
        Family::Pac => &[0.1, 1.0, 10.0, 100.0],
        Family::Cdios => &[10.0, 100.0, 1000.0, 10000.0],
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Level {
    Info,
    Warn,
    Error,
}

#[derive(Debug, Clone)]
pub struct EventLine {
    pub at: Instant,
    pub level: Level,
    pub text: String,
    /// How many times it happened ([`App::log_folded`]); 1 for most lines.
    pub count: u32,
}

impl EventLine {
    /// The text with its count when it happened more than once.
    pub fn shown(&self) -> String {
        if self.count > 1 {
            format!("{} (×{})", self.text, self.count)
        } else {
            self.text.clone()
        }
    }
}

/// How far back [`App::log_folded`] looks for the same line: enough for a
/// few devices flapping between "no answer" and "answers again" at once.
pub const FOLD_WINDOW: usize = 32;

/// A link and its worker, as the status bar shows it.
#[derive(Debug, Clone)]
pub struct LinkView {
    pub name: String,
    pub families: Vec<Family>,
    /// Polls per second asked for.
    pub rate: f64,
    /// Time between the last two round starts (the achieved period).
    pub period: Option<Duration>,
    /// How long the last round's I/O took.
    pub busy: Option<Duration>,
    pub answers: u64,
    pub timeouts: u64,
    pub errors: u64,
    pub discovered: bool,
    pub ended: Option<String>,
}

impl LinkView {
    pub fn new(name: impl Into<String>, families: Vec<Family>, rate: f64) -> Self {
        Self {
            name: name.into(),
            families,
            rate,
            period: None,
            busy: None,
            answers: 0,
            timeouts: 0,
            errors: 0,
            discovered: false,
            ended: None,
        }
    }

    /// Polls per second achieved, once a second round has started.
    pub fn achieved_hz(&self) -> Option<f64> {
        self.period.filter(|p| !p.is_zero()).map(|p| 1.0 / p.as_secs_f64())
    }

    /// Data older than this is stale: three periods, and never less than 1 s.
    pub fn stale_after(&self) -> Duration {
        let p = self.period.unwrap_or(Duration::from_secs_f64(1.0 / self.rate.max(0.1)));
        (p * 3).max(Duration::from_secs(1))
    }
}

/// A device and what is known of it.
#[derive(Debug, Clone)]
pub struct DeviceView {
    pub key: Address,
    pub link: LinkId,
    /// The last good snapshot.
    pub snap: Option<Snapshot>,
    pub ok_at: Option<Instant>,
    /// The failure of the latest poll, if it failed: the data is stale.
    pub error: Option<String>,
    /// When each field last changed (field names as [`changed_fields`] gives them).
    pub changed: HashMap<&'static str, Instant>,
    /// Position, velocity and current over the last 30 s, for the chart.
    pub history: History,
}

/// The chart of one device, as the `p` key asks for it to be written to
/// SVG: the dashboard's loop writes it (the App does no I/O) and reports
/// back with [`Event::Saved`].
#[derive(Debug, Clone, PartialEq)]
pub struct ChartRequest {
    pub device: Address,
    pub title: String,
    pub traces: Vec<Trace>,
}

/// How long a notice (a snapshot written) stays in the status bar.
pub const NOTICE: Duration = Duration::from_secs(10);

/// What the screen shows over the panes.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Mode {
    Normal,
    Help,
    /// Typing a target position for the selected device.
    Target(String),
}

/// A request for a worker.
#[derive(Debug, Clone, PartialEq)]
pub struct Outgoing {
    pub link: LinkId,
    pub msg: ToWorker,
}

pub struct App {
    pub links: Vec<LinkView>,
    pub devices: Vec<DeviceView>,
    pub selected: usize,
    pub events: VecDeque<EventLine>,
    /// Lines scrolled back from the newest event.
    pub scroll: usize,
    pub mode: Mode,
    /// Index into [`jog_steps`].
    pub jog: usize,
    pub rate: f64,
    pub started: Instant,
    pub now: Instant,
    pub quit: bool,
    /// The user moved the selection: it follows its device as others appear.
    pub chosen: bool,
    /// Devices this dashboard sent a motion to (home, jog, go to), with
    /// their link: what SIGTERM / SIGHUP, a panic or a failed draw halt
    /// before the dashboard exits.
    pub moved: Vec<(LinkId, Address)>,
    /// Why the dashboard halted what it moved and quit, other than a signal
    /// (a panic, a failed draw).
    pub stopped: Option<String>,
    /// The chart of the selected device is shown (`c`).
    pub chart: bool,
    /// Every device in one table instead of the list and the detail (`v`).
    pub overview: bool,
    /// A chart to write to SVG (`p`), taken by the dashboard's loop.
    pub snapshot: Option<ChartRequest>,
    /// A line for the status bar until it is older than [`NOTICE`].
    pub notice: Option<(Instant, String)>,
}

impl App {
    pub fn new(links: Vec<LinkView>, rate: f64, now: Instant) -> Self {
        Self {
            links,
            devices: Vec::new(),
            selected: 0,
            events: VecDeque::new(),
            scroll: 0,
            mode: Mode::Normal,
            jog: 1,
            rate,
            started: now,
            now,
            quit: false,
            chosen: false,
            moved: Vec::new(),
            stopped: None,
            chart: false,
            overview: false,
            snapshot: None,
            notice: None,
        }
    }

    /// The status bar's notice, while it is recent.
    pub fn notice(&self) -> Option<&str> {
        self.notice
            .as_ref()
            .filter(|(at, _)| self.now.saturating_duration_since(*at) < NOTICE)
            .map(|(_, text)| text.as_str())
    }

    /// The selected device's motion over the window, with a title; `None`
    /// when it has no motion values (the PA-CONTROL controller line) or
    /// has not answered yet.
    pub fn chart_of(&self, d: &DeviceView) -> Option<ChartRequest> {
        let (units, _, _) = history::motion(d.snap.as_ref()?)?;
        Some(ChartRequest {
            device: d.key,
            title: format!("{} · last {} s", d.key.label(), history::WINDOW.as_secs()),
            traces: d.history.traces(units, self.now),
        })
    }

    pub fn selected(&self) -> Option<&DeviceView> {
        self.devices.get(self.selected)
    }

    pub fn device(&self, key: Address) -> Option<&DeviceView> {
        self.devices.iter().find(|d| d.key == key)
    }

    pub fn log(&mut self, level: Level, text: impl Into<String>) {
        self.events.push_back(EventLine { at: self.now, level, text: text.into(), count: 1 });
        while self.events.len() > EVENT_LINES {
            self.events.pop_front();
        }
        if self.scroll > 0 {
            // Keep the lines the user scrolled to in place.
            self.scroll = (self.scroll + 1).min(self.events.len().saturating_sub(1));
        }
    }

    /// As [`log`](Self::log), but a line already among the last
    /// [`FOLD_WINDOW`] moves to the bottom with its count raised: at a few
    /// percent frame loss, devices flap between "no answer" and "answers
    /// again", and one line each with a count keeps the pane readable.
    pub fn log_folded(&mut self, level: Level, text: String) {
        let n = self.events.len();
        let hit = (n.saturating_sub(FOLD_WINDOW)..n).rev().find(|&i| self.events[i].text == text);
        let Some(i) = hit else { return self.log(level, text) };
        let mut line = self.events.remove(i).expect("found above");
        line.count += 1;
        line.at = self.now;
        line.level = level;
        self.events.push_back(line);
    }

    /// Why a device's data is not current, or `None` when it is.
    pub fn stale(&self, d: &DeviceView) -> Option<String> {
        if let Some(e) = &d.error {
            return Some(e.clone());
        }
        if let Some(why) = &self.links[d.link].ended {
            return Some(why.clone());
        }
        let at = d.ok_at?;
        let age = self.now.saturating_duration_since(at);
        (age > self.links[d.link].stale_after()).then(|| format!("no data for {:.1} s", age.as_secs_f64()))
    }

    /// Whether `field` of a device changed within [`HIGHLIGHT`].
    pub fn is_fresh_change(&self, d: &DeviceView, field: &str) -> bool {
        d.changed.get(field).is_some_and(|t| self.now.saturating_duration_since(*t) < HIGHLIGHT)
    }

    pub fn jog_step(&self) -> Option<f64> {
        let f = self.selected()?.key.family();
        let steps = jog_steps(f);
        Some(steps[self.jog.min(steps.len() - 1)])
    }

    /// Applies an event; returns what must go to the workers.
    pub fn handle(&mut self, ev: Event) -> Vec<Outgoing> {
        match ev {
            Event::Tick(now) => {
                self.now = self.now.max(now);
                vec![]
            }
            Event::Link(l) => {
                self.on_link(l);
                vec![]
            }
            Event::Key(k) if k.kind != KeyEventKind::Release => {
                let out = self.on_key(k);
                for o in &out {
                    if let ToWorker::Act(key, action) = o.msg {
                        if action.is_motion() && !self.moved.contains(&(o.link, key)) {
                            self.moved.push((o.link, key));
                        }
                    }
                }
                out
            }
            Event::Key(_) => vec![],
            Event::Terminate(signal) => self.halt_moved_and_quit(crate::clock::stop::signal_name(signal)),
            Event::Stop(why) => {
                let out = self.halt_moved_and_quit(&why);
                self.stopped.get_or_insert(why);
                out
            }
            Event::Saved(result) => {
                match result {
                    Ok(path) => {
                        self.log(Level::Info, format!("chart written to {path}"));
                        self.notice = Some((self.now, format!("chart written to {path}")));
                    }
                    Err(e) => {
                        self.log(Level::Error, format!("chart not written: {e}"));
                        self.notice = Some((self.now, format!("chart not written: {e}")));
                    }
                }
                vec![]
            }
        }
    }

    /// The terminal closed, the process is told to end, or a panic or a
    /// failed draw ends the dashboard (`why` says which): nobody will watch
    /// the axes any more, so what this dashboard set moving is halted (each
    /// worker runs its halts before it sees Quit). Other devices are left
    /// alone, as `q` leaves them all.
    pub fn halt_moved_and_quit(&mut self, why: &str) -> Vec<Outgoing> {
        self.log(Level::Warn, format!("{why}: halting what this dashboard moved, then quitting"));
        let mut out: Vec<Outgoing> =
            self.moved.iter().map(|&(link, key)| Outgoing { link, msg: ToWorker::Act(key, Action::Halt) }).collect();
        out.extend(self.quit());
        out
    }

    fn on_link(&mut self, ev: LinkEvent) {
        match ev {
            LinkEvent::Discovered { link, devices, errors } => {
                self.links[link].discovered = true;
                let name = self.links[link].name.clone();
                for e in errors {
                    self.log(Level::Error, format!("{name}: {e}"));
                }
                if devices.is_empty() {
                    self.log(Level::Warn, format!("{name}: no devices found"));
                }
                let selected = self.selected().map(|d| d.key);
                for key in devices {
                    if self.device(key).is_none() {
                        self.devices.push(DeviceView {
                            key,
                            link,
                            snap: None,
                            ok_at: None,
                            error: None,
                            changed: HashMap::new(),
                            history: History::default(),
                        });
                    }
                }
                self.devices.sort_by_key(|d| d.key);
                self.selected = match selected.filter(|_| self.chosen) {
                    Some(k) => self.devices.iter().position(|d| d.key == k).unwrap_or(0),
                    None => 0,
                };
            }
            LinkEvent::Polled { link, device, at, result, health } => {
                let lv = &mut self.links[link];
                match health {
                    Health::Answer => lv.answers += 1,
                    Health::Timeout => lv.timeouts += 1,
                    Health::Error => lv.errors += 1,
                }
                let Some(i) = self.devices.iter().position(|d| d.key == device) else { return };
                let mut note = None;
                let d = &mut self.devices[i];
                match result {
                    Ok(snap) => {
                        if let Some(old) = &d.snap {
                            for f in changed_fields(old, &snap) {
                                d.changed.insert(f, at);
                            }
                        }
                        if d.error.take().is_some() {
                            note = Some((Level::Info, format!("{}: answers again", device.label())));
                        }
                        d.history.push(&snap, at);
                        d.snap = Some(snap);
                        d.ok_at = Some(at);
                    }
                    Err(e) => {
                        if d.error.is_none() {
                            note = Some((Level::Error, format!("{}: {e}", device.label())));
                        }
                        d.error = Some(e);
                    }
                }
                self.now = self.now.max(at);
                if let Some((level, text)) = note {
                    self.log_folded(level, text);
                }
            }
            LinkEvent::Acted { device, what, at, result, .. } => {
                self.now = self.now.max(at);
                let who = device.map_or_else(|| "bus".to_string(), |d| d.label());
                match result {
                    Ok(text) => self.log(Level::Info, format!("{who}: {what}: {text}")),
                    Err(e) => self.log(Level::Error, format!("{who}: {what} failed: {e}")),
                }
            }
            LinkEvent::Cycle { link, busy, period } => {
                let lv = &mut self.links[link];
                lv.busy = Some(busy);
                if !period.is_zero() {
                    lv.period = Some(period);
                }
            }
            LinkEvent::Down { link, why } => {
                let name = self.links[link].name.clone();
                let first = self.links[link].ended.is_none();
                self.links[link].ended = Some(format!("link lost: {why}"));
                let text = format!("{name}: link lost ({why}); reopening");
                if first {
                    self.log(Level::Error, text);
                } else {
                    self.log_folded(Level::Error, text);
                }
            }
            LinkEvent::Reopened { link } => {
                self.links[link].ended = None;
                let name = self.links[link].name.clone();
                self.log_folded(Level::Info, format!("{name}: reopened"));
            }
            LinkEvent::Ended { link, why } => {
                let name = self.links[link].name.clone();
                self.links[link].ended = Some(why.clone());
                self.log(Level::Error, format!("{name}: {why}"));
            }
        }
    }

    fn to_all(&self, msg: ToWorker) -> Vec<Outgoing> {
        (0..self.links.len()).map(|link| Outgoing { link, msg: msg.clone() }).collect()
    }

    fn act(&mut self, action: Action) -> Vec<Outgoing> {
        let Some(d) = self.selected() else {
            self.log(Level::Warn, "no device selected");
            return vec![];
        };
        let (key, link) = (d.key, d.link);
        if let Err(why) = applies(key, action) {
            self.log(Level::Warn, format!("{}: {why}", key.label()));
            return vec![];
        }
        self.log(Level::Info, format!("{}: {} sent", key.label(), action.name()));
        vec![Outgoing { link, msg: ToWorker::Act(key, action) }]
    }

    fn on_key(&mut self, k: KeyEvent) -> Vec<Outgoing> {
        let action = keys::lookup(&k);
        // Halt-all works on every screen, the prompt included.
        if action == Some(KeyAction::HaltAll) {
            self.log(Level::Warn, "HALT ALL sent to every link");
            return self.to_all(ToWorker::HaltAll);
        }
        match self.mode.clone() {
            Mode::Help => {
                self.mode = Mode::Normal;
                if action == Some(KeyAction::Quit) && k.code != KeyCode::Esc {
                    return self.quit();
                }
                return vec![];
            }
            Mode::Target(text) => return self.on_prompt_key(k, text),
            Mode::Normal => {}
        }
        let Some(action) = action else { return vec![] };
        match action {
            KeyAction::HaltAll => unreachable!("handled above"),
            KeyAction::Up => {
                self.chosen = true;
                self.selected = self.selected.saturating_sub(1);
                vec![]
            }
            KeyAction::Down => {
                self.chosen = true;
                self.selected = (self.selected + 1).min(self.devices.len().saturating_sub(1));
                vec![]
            }
            KeyAction::Home => self.act(Action::Home),
            KeyAction::Reset => self.act(Action::Reset),
            KeyAction::Halt => self.act(Action::Halt),
            KeyAction::Enable => self.act(Action::Enable),
            KeyAction::Disable => self.act(Action::Disable),
            KeyAction::JogPlus | KeyAction::JogMinus => match self.jog_step() {
                Some(s) => self.act(Action::Jog(if action == KeyAction::JogPlus { s } else { -s })),
                None => vec![],
            },
            KeyAction::StepSmaller => {
                self.jog = self.jog.saturating_sub(1);
                vec![]
            }
            KeyAction::StepLarger => {
                self.jog = (self.jog + 1).min(3);
                vec![]
            }
            KeyAction::GoTo => {
                if let Some(d) = self.selected() {
                    match applies(d.key, Action::MoveTo(0.0)) {
                        Ok(()) => self.mode = Mode::Target(String::new()),
                        Err(why) => {
                            let label = d.key.label();
                            self.log(Level::Warn, format!("{label}: {why}"));
                        }
                    }
                }
                vec![]
            }
            KeyAction::Online => self.act(Action::Online),
            KeyAction::Offline => self.act(Action::Offline),
            KeyAction::RateDown | KeyAction::RateUp => {
                let i = RATES.iter().position(|r| *r >= self.rate).unwrap_or(RATES.len() - 1);
                let i = if action == KeyAction::RateUp {
                    (i + usize::from(RATES[i] <= self.rate)).min(RATES.len() - 1)
                } else {
                    i.saturating_sub(1)
                };
                self.rate = RATES[i];
                for l in &mut self.links {
                    l.rate = RATES[i];
                }
                self.to_all(ToWorker::SetRate(self.rate))
            }
            KeyAction::ScrollUp => {
                self.scroll = (self.scroll + 5).min(self.events.len().saturating_sub(1));
                vec![]
            }
            KeyAction::ScrollDown => {
                self.scroll = self.scroll.saturating_sub(5);
                vec![]
            }
            KeyAction::Rescan => {
                self.log(Level::Info, "rescan sent to every link");
                self.to_all(ToWorker::Rescan)
            }
            KeyAction::Help => {
                self.mode = Mode::Help;
                vec![]
            }
            KeyAction::Chart => {
                self.chart = !self.chart;
                vec![]
            }
            KeyAction::Overview => {
                self.overview = !self.overview;
                vec![]
            }
            KeyAction::Snapshot => {
                match self.selected().map(|d| (d.key, self.chart_of(d))) {
                    None => self.log(Level::Warn, "no device selected"),
                    Some((key, None)) => self.log(Level::Warn, format!("{}: no motion values to chart", key.label())),
                    Some((_, Some(req))) => self.snapshot = Some(req),
                }
                vec![]
            }
            KeyAction::Quit => self.quit(),
        }
    }

    fn quit(&mut self) -> Vec<Outgoing> {
        self.quit = true;
        self.to_all(ToWorker::Quit)
    }

    fn on_prompt_key(&mut self, k: KeyEvent, mut text: String) -> Vec<Outgoing> {
        match k.code {
            KeyCode::Esc => {
                self.mode = Mode::Normal;
                vec![]
            }
            KeyCode::Backspace => {
                text.pop();
                self.mode = Mode::Target(text);
                vec![]
            }
            KeyCode::Char(c) if c.is_ascii_digit() || matches!(c, '.' | '-' | '+' | 'e' | 'E') => {
                if text.len() < 24 {
                    text.push(c);
                }
                self.mode = Mode::Target(text);
                vec![]
            }
            KeyCode::Enter => {
                self.mode = Mode::Normal;
                let Some(d) = self.selected() else { return vec![] };
                let label = d.key.label();
                match self.check_target(d, &text) {
                    Ok(pos) => self.act(Action::MoveTo(pos)),
                    Err(why) => {
                        self.log(Level::Error, format!("{label}: {why}"));
                        vec![]
                    }
                }
            }
            _ => vec![],
        }
    }

    /// The same checks as the CLI, against the limits last read; the worker
    /// checks again against freshly read ones before sending.
    fn check_target(&self, d: &DeviceView, text: &str) -> Result<f64, String> {
        let pos: f64 = text.trim().parse().map_err(|_| format!("{text:?} is not a number; nothing was sent"))?;
        if !pos.is_finite() {
            return Err(format!("target position {pos} is not a finite number"));
        }
        if let (Some(snap), Some(at)) = (&d.snap, MotionTarget::try_from(d.key).ok()) {
            snap.check_target(at, pos)?;
        }
        Ok(pos)
    }
}

/// Whether a family has the action at all (said before anything is sent).
pub fn applies(key: Address, action: Action) -> Result<(), &'static str> {
    use Action::*;
    match (key, action) {
        (_, Halt | Reset) => Ok(()),
        (Address::PowerCube { module: _ }, Home | Jog(_) | MoveTo(_)) => Ok(()),
        (Address::PowerCube { module: _ }, Enable | Disable) => {
            Err("PowerCube modules have no enable / disable: r (reset) switches the servo on, s (halt) stops it")
        }
        (Address::Pac { axis: Some(_) }, Home | Enable | Disable | Jog(_) | MoveTo(_)) => Ok(()),
        (Address::Pac { axis: None } | Address::Pac { axis: Some(_) }, Online | Offline) => Ok(()),
        (Address::Pac { axis: None }, _) => Err("select an axis for this (the controller line takes r, s, o, f)"),
        (Address::Cdios { .. }, Enable | Disable | Jog(_) | MoveTo(_)) => Ok(()),
        (Address::Cdios { .. }, Home) => Err("the Cdios 6168 has no homing command: set the position instead"),
        (_, Online | Offline) => Err("online / offline is a PA-CONTROL mode (select the PA-CONTROL)"),
    }
}

/// The fields that differ between two snapshots of one device.
pub fn changed_fields(old: &Snapshot, new: &Snapshot) -> Vec<&'static str> {
    new.changed_fields(&**old)
}
