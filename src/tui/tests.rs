//! The dashboard on a virtual-time bench: the App, real workers and device
//! sources, the simulators, and ratatui's TestBackend. Snapshots are of the
//! text on screen; colours are checked cell by cell where they carry meaning.

use crate::address::Address;
use std::sync::Arc;
use std::time::Duration;

use crossterm::event::{KeyCode, KeyEvent, KeyEventKind, KeyModifiers};
use ratatui::backend::TestBackend;
use ratatui::style::Color;
use ratatui::Terminal;

use super::app::{App, LinkView, Mode};
use super::cdios::CdiosSource;
use super::event::{Event, LinkEvent, ToWorker};
use super::pac::PacSource;
use super::powercube::CubeSource;
use super::source::{DeviceSource, Snapshot};
use super::ui;
use super::ui::cdios::CdiosSnap;
use super::ui::pac::{PacAxisSnap, PacCtrlSnap};
use super::ui::powercube::CubeSnap;
use super::worker::LinkWorker;
use crate::clock::{Clock, VirtualClock};
use crate::family::Family;
use crate::link::mem::Fault;
use crate::link::SerialFormat;
use crate::link::{CanLink, LinkError};
use crate::proto::cdios::NodeId;
use crate::proto::powercube::flags::state;
use crate::proto::CanFrame;
use crate::session::bus::CanBus;
use crate::session::cdios::Cdios;
use crate::session::pac::Pac;
use crate::session::powercube::PowerCube;
use crate::session::RetryPolicy;
use crate::sim::bench::Bench;
use crate::sim::shared::lock;

/// Drops every frame the devices send: a link that stops answering.
struct Silence;
impl Fault for Silence {
    fn device_frame(&mut self, _frame: CanFrame, _out: &mut Vec<crate::link::mem::Delivery>) {}
}

struct Rig {
    clock: VirtualClock,
    bench: Bench,
    workers: Vec<LinkWorker>,
    app: App,
    sent: Vec<ToWorker>,
}

impl Rig {
    /// The contract bench; every family that has a source, each on its link.
    fn new() -> Self {
        Self::with_can(|link| link)
    }

    /// [`Rig::new`] with the dashboard's CAN link passed through `wrap`.
    fn with_can(wrap: impl FnOnce(Box<dyn CanLink>) -> Box<dyn CanLink>) -> Self {
        let clock = VirtualClock::new();
        let shared: Arc<dyn Clock> = Arc::new(clock.clone());
        let bench = Bench::contract(Arc::clone(&shared));
        let can = CanBus::new(wrap(Box::new(bench.bus.open())), Arc::clone(&shared));
        let cube: Box<dyn DeviceSource> = Box::new(CubeSource::new(
            PowerCube::over_can(Box::new(can.port(Family::PowerCube))).with_clock(Arc::clone(&shared)),
            None,
        ));
        let cdios: Box<dyn DeviceSource> = Box::new(CdiosSource::new(
            Cdios::new(Box::new(can.port(Family::Cdios))).with_clock(Arc::clone(&shared)),
            NodeId::new(1).unwrap(),
            None,
            RetryPolicy::default(),
        ));
        let sources = vec![cube, cdios];
        let pac_link: Box<dyn crate::link::ByteLink> = Box::new(bench.pac_link(Arc::clone(&shared)));
        let pac = Pac::new(pac_link, 9600, SerialFormat::F7N1).with_clock(Arc::clone(&shared));
        let pac_sources: Vec<Box<dyn DeviceSource>> = vec![Box::new(PacSource::new(pac, None))];
        let links = vec![
            LinkView::new("sim CAN", sources.iter().map(|s| s.family()).collect(), 10.0),
            LinkView::new("sim RS232", vec![Family::Pac], 10.0),
        ];
        let workers = vec![
            LinkWorker::new(0, sources, Arc::clone(&shared), 10.0),
            LinkWorker::new(1, pac_sources, Arc::clone(&shared), 10.0),
        ];
        let app = App::new(links, 10.0, clock.now());
        let mut rig = Self { clock, bench, workers, app, sent: Vec::new() };
        for i in 0..rig.workers.len() {
            let ev = rig.workers[i].discover();
            rig.feed(ev);
        }
        rig
    }

    fn feed(&mut self, ev: LinkEvent) {
        let out = self.app.handle(Event::Link(ev));
        assert!(out.is_empty(), "worker reports never ask the workers for anything");
    }

    /// One poll round on every link, reports fed to the App.
    fn round(&mut self) {
        for i in 0..self.workers.len() {
            let mut events = Vec::new();
            let quit = self.workers[i].round(&mut Vec::new, &mut |ev| events.push(ev));
            assert!(!quit);
            for ev in events {
                self.feed(ev);
            }
        }
    }

    fn advance(&mut self, d: Duration) {
        self.clock.advance(d);
        self.app.handle(Event::Tick(self.clock.now()));
    }

    /// A key press; what the App asks goes to the workers at once.
    fn key(&mut self, code: KeyCode) {
        let outs = self.app.handle(Event::Key(KeyEvent::new(code, KeyModifiers::NONE)));
        for o in outs {
            self.sent.push(o.msg.clone());
            let mut events = Vec::new();
            self.workers[o.link].handle(vec![o.msg], &mut |ev| events.push(ev));
            for ev in events {
                self.feed(ev);
            }
        }
    }

    fn keys(&mut self, text: &str) {
        for c in text.chars() {
            self.key(KeyCode::Char(c));
        }
    }

    fn select(&mut self, key: Address) {
        self.app.selected = self.app.devices.iter().position(|d| d.key == key).expect("device listed");
    }

    fn terminal(&self, w: u16, h: u16) -> Terminal<TestBackend> {
        let mut t = Terminal::new(TestBackend::new(w, h)).unwrap();
        t.draw(|f| ui::draw(f, &self.app)).unwrap();
        t
    }

    fn screen(&self, w: u16, h: u16) -> String {
        self.terminal(w, h).backend().to_string()
    }

    fn cube(&self, id: u8) -> (u32, f32) {
        let pc = lock(&self.bench.powercube);
        let m = pc.module(id).unwrap();
        (m.cube_state(), m.velocity())
    }

    /// Where `text` starts on the screen, as (x, y).
    fn find(t: &Terminal<TestBackend>, text: &str) -> Option<(u16, u16)> {
        let buf = t.backend().buffer();
        for y in 0..buf.area.height {
            let row: String = (0..buf.area.width).map(|x| buf[(x, y)].symbol().to_string()).collect();
            if let Some(i) = row.find(text) {
                return Some((row[..i].chars().count() as u16, y));
            }
        }
        None
    }
}

#[test]
fn scan_finds_the_contract_modules() {
    let rig = Rig::new();
    let keys: Vec<_> = rig.app.devices.iter().map(|d| d.key).collect();
    assert!(
        keys.starts_with(&[
            Address::PowerCube { module: 3 },
            Address::PowerCube { module: 5 },
            Address::PowerCube { module: 17 }
        ]),
        "{keys:?}"
    );
}

#[test]
fn powercube_pane_idle() {
    let mut rig = Rig::new();
    rig.round();
    rig.advance(Duration::from_millis(100));
    rig.round();
    insta::assert_snapshot!("powercube_idle_80x24", rig.screen(80, 24));
    insta::assert_snapshot!("powercube_idle_200x50", rig.screen(200, 50));
}

#[test]
fn powercube_pane_moving_highlights_changes() {
    let mut rig = Rig::new();
    rig.round();
    rig.select(Address::PowerCube { module: 17 });
    rig.key(KeyCode::Char('g'));
    rig.keys("0.5");
    assert_eq!(rig.app.mode, Mode::Target("0.5".into()));
    insta::assert_snapshot!("powercube_target_prompt_80x24", rig.screen(80, 24));
    rig.key(KeyCode::Enter);
    assert!(rig.sent.contains(&ToWorker::Act(Address::PowerCube { module: 17 }, super::source::Action::MoveTo(0.5))));
    rig.advance(Duration::from_millis(1500));
    rig.round();
    insta::assert_snapshot!("powercube_moving_80x24", rig.screen(80, 24));
    let t = rig.terminal(80, 24);
    let (x, y) = Rig::find(&t, "0.0700").expect("position shown");
    assert_eq!(t.backend().buffer()[(x, y)].bg, Color::Cyan, "a changed value is highlighted");
    // Unchanged for longer than the highlight: plain again.
    rig.advance(Duration::from_secs(20));
    rig.round();
    rig.advance(Duration::from_secs(2));
    rig.round();
    let t = rig.terminal(80, 24);
    let (x, y) = Rig::find(&t, "0.5000").expect("arrived");
    assert_ne!(t.backend().buffer()[(x, y)].bg, Color::Cyan);
}

#[test]
fn powercube_pane_error_state() {
    let mut rig = Rig::new();
    lock(&rig.bench.powercube).module_mut(5).unwrap().inject_error(state::TOW_ERROR | state::CURLIMIT);
    rig.round();
    rig.select(Address::PowerCube { module: 5 });
    insta::assert_snapshot!("powercube_error_80x24", rig.screen(80, 24));
    insta::assert_snapshot!("powercube_error_200x50", rig.screen(200, 50));
    let t = rig.terminal(80, 24);
    let (x, y) = Rig::find(&t, "STATE_TOW_ERROR").unwrap();
    assert_eq!(t.backend().buffer()[(x, y)].fg, Color::Red, "error flags are red");
    let (x, y) = Rig::find(&t, "STATE_CURLIMIT").unwrap();
    assert_eq!(t.backend().buffer()[(x, y)].fg, Color::Yellow, "warnings are yellow");
    let (x, y) = Rig::find(&t, "STATE_HALTED").unwrap();
    assert_eq!(t.backend().buffer()[(x, y)].fg, Color::Reset, "information is plain");
    // Moving a faulted module is refused by the worker, nothing sent.
    rig.keys("+");
    let last = rig.app.events.back().unwrap().text.clone();
    assert!(last.contains("not ready") && last.contains("nothing was sent"), "{last}");
    // Reset clears it.
    rig.keys("r");
    rig.round();
    assert_eq!(rig.cube(5).0 & state::ERROR, 0);
}

#[test]
fn stale_link_is_shown_as_stale() {
    let mut rig = Rig::new();
    rig.round();
    rig.bench.bus.set_fault(Some(Box::new(Silence)));
    rig.advance(Duration::from_millis(100));
    rig.round();
    let d = rig.app.device(Address::PowerCube { module: 3 }).unwrap();
    assert!(rig.app.stale(d).is_some());
    assert!(rig.app.links[0].timeouts >= 3, "timeouts counted: {:?}", rig.app.links[0]);
    insta::assert_snapshot!("stale_link_80x24", rig.screen(80, 24));
    insta::assert_snapshot!("stale_link_200x50", rig.screen(200, 50));
    // It answers again: current again.
    rig.bench.bus.set_fault(None);
    rig.round();
    let d = rig.app.device(Address::PowerCube { module: 3 }).unwrap();
    assert!(rig.app.stale(d).is_none());
}

#[test]
fn old_data_turns_stale_without_a_failed_poll() {
    let mut rig = Rig::new();
    rig.round();
    rig.advance(Duration::from_secs(5));
    let d = rig.app.device(Address::PowerCube { module: 3 }).unwrap();
    assert_eq!(rig.app.stale(d).as_deref(), Some("no data for 5.0 s"));
}

#[test]
fn help_overlay_lists_every_key() {
    let mut rig = Rig::new();
    rig.round();
    rig.keys("?");
    let screen = rig.screen(80, 24);
    for b in super::keys::KEYS {
        assert!(screen.contains(b.keys), "help lacks {}", b.keys);
    }
    insta::assert_snapshot!("help_80x24", screen);
    rig.keys("x");
    assert_eq!(rig.app.mode, Mode::Normal);
}

#[test]
fn halt_all_reaches_every_device() {
    let mut rig = Rig::new();
    rig.round();
    rig.select(Address::PowerCube { module: 3 });
    rig.keys("h");
    rig.select(Address::PowerCube { module: 17 });
    rig.keys("]]");
    rig.keys("+");
    rig.advance(Duration::from_millis(300));
    rig.round();
    assert_ne!(rig.cube(3).1, 0.0, "module 3 homing");
    assert_ne!(rig.cube(17).1, 0.0, "module 17 jogging");
    // From the prompt, too: space is never part of a target.
    rig.keys("g1");
    rig.key(KeyCode::Char(' '));
    for m in [3, 5, 17] {
        let (cube, vel) = rig.cube(m);
        assert_ne!(cube & state::HALTED, 0, "module {m} halted");
        assert_eq!(vel, 0.0, "module {m} stands");
    }
    assert!(rig
        .sent
        .iter()
        .all(|m| *m != ToWorker::Act(Address::PowerCube { module: 17 }, super::source::Action::MoveTo(1.0))));
}

#[test]
fn targets_are_checked_like_the_cli() {
    let mut rig = Rig::new();
    rig.round();
    rig.select(Address::PowerCube { module: 17 });
    rig.keys("g5");
    rig.key(KeyCode::Enter);
    assert!(rig.sent.is_empty(), "nothing sent: {:?}", rig.sent);
    let last = &rig.app.events.back().unwrap().text;
    assert_eq!(last, "PowerCube 17: target position 5 exceeds module 17's MaxPos = 1; nothing was sent");
    rig.keys("g1..2");
    rig.key(KeyCode::Enter);
    assert!(rig.sent.is_empty());
    // The worker checks again with fresh limits: a direct request fails the same way.
    let mut events = Vec::new();
    rig.workers[0].handle(
        vec![ToWorker::Act(Address::PowerCube { module: 17 }, super::source::Action::MoveTo(-1.0))],
        &mut |e| events.push(e),
    );
    let LinkEvent::Acted { result: Err(e), .. } = &events[0] else { panic!("{events:?}") };
    assert!(e.contains("MinPos = 0"), "{e}");
    assert_eq!(rig.cube(17).1, 0.0);
}

#[test]
fn actions_a_family_lacks_are_refused_before_sending() {
    let mut rig = Rig::new();
    rig.round();
    rig.keys("eo");
    assert!(rig.sent.is_empty());
    assert!(rig.app.events.iter().any(|e| e.text.contains("no enable / disable")));
}

#[test]
fn rate_keys_reach_every_worker() {
    let mut rig = Rig::new();
    rig.keys(">");
    assert_eq!(rig.app.rate, 20.0);
    assert_eq!(rig.workers[0].rate(), 20.0);
    rig.keys("<<<");
    assert_eq!(rig.app.rate, 2.0);
    assert_eq!(rig.workers[0].rate(), 2.0);
}

#[test]
fn quitting_tells_every_worker() {
    let mut rig = Rig::new();
    rig.keys("q");
    assert!(rig.app.quit);
    assert_eq!(rig.sent, vec![ToWorker::Quit; rig.workers.len()]);
}

#[test]
fn snapshots_keep_their_family() {
    let mut rig = Rig::new();
    rig.round();
    for d in &rig.app.devices {
        let snap = d.snap.as_ref().unwrap_or_else(|| panic!("{:?} has no reading", d.key));
        let of_its_family = match d.key {
            Address::PowerCube { module: _ } => snap.get::<CubeSnap>().is_some(),
            Address::Cdios { .. } => snap.get::<CdiosSnap>().is_some(),
            Address::Pac { axis: None } => snap.get::<PacCtrlSnap>().is_some(),
            Address::Pac { axis: Some(_) } => snap.get::<PacAxisSnap>().is_some(),
        };
        assert!(of_its_family, "{:?} has {snap:?}", d.key);
    }
}

impl Rig {
    /// Online, and `axis` referenced (the controller moves only referenced axes).
    fn pac_online_and_referenced(&mut self, axis: u8) {
        self.select(Address::Pac { axis: None });
        self.keys("o");
        self.select(Address::Pac { axis: Some(axis) });
        self.keys("h");
        for _ in 0..600 {
            self.advance(Duration::from_millis(100));
            self.round();
            if lock(&self.bench.pac).axis_referenced(axis) == Some(true) && lock(&self.bench.pac).busy().is_none() {
                break;
            }
        }
        self.round();
        assert!(self.app.stale(self.app.device(Address::Pac { axis: Some(axis) }).unwrap()).is_none());
    }

    fn pac_axis(&self, axis: u8) -> (u8, f64) {
        let mut pac = lock(&self.bench.pac);
        pac.advance(self.clock.now());
        (pac.axis_status(axis).unwrap(), pac.axis_speed(axis).unwrap())
    }

    fn cdios_motor(&self, m: u8) -> (bool, f64) {
        let mut node = lock(&self.bench.cdios);
        node.poll(self.clock.now(), &mut Vec::new());
        let motor = node.module(m).unwrap();
        (motor.running(), motor.speed_rpm())
    }

    /// Every family moving: module 3 homing, module 17 jogging, PA axis 1
    /// moving online, Cdios module 0 on a long goto.
    fn everything_moving(&mut self) {
        self.round();
        self.pac_online_and_referenced(1);
        self.keys("g5000");
        self.key(KeyCode::Enter);
        self.select(Address::PowerCube { module: 3 });
        self.keys("h");
        self.select(Address::PowerCube { module: 17 });
        self.keys("]]+");
        self.select(Address::Cdios { node: 1, module: 0 });
        self.keys("eg1000000");
        self.key(KeyCode::Enter);
        self.advance(Duration::from_millis(300));
        self.round();
    }
}

#[test]
fn pac_panes() {
    let mut rig = Rig::new();
    rig.round();
    rig.select(Address::Pac { axis: None });
    insta::assert_snapshot!("pac_controller_80x24", rig.screen(80, 24));
    rig.pac_online_and_referenced(2);
    rig.keys("g2500");
    rig.key(KeyCode::Enter);
    rig.advance(Duration::from_millis(500));
    rig.round();
    insta::assert_snapshot!("pac_axis_moving_80x24", rig.screen(80, 24));
    insta::assert_snapshot!("pac_axis_moving_200x50", rig.screen(200, 50));
    // Outside the traverse area: refused like pac-move, nothing sent.
    let before = rig.sent.len();
    rig.keys("g99999");
    rig.key(KeyCode::Enter);
    assert_eq!(rig.sent.len(), before);
    let last = &rig.app.events.back().unwrap().text;
    assert!(last.contains("outside axis 2's traverse area"), "{last}");
}

#[test]
fn pac_reference_drive_keeps_the_line_for_polls() {
    let mut rig = Rig::new();
    rig.round();
    rig.select(Address::Pac { axis: None });
    rig.keys("o");
    rig.select(Address::Pac { axis: Some(1) });
    rig.keys("h");
    rig.advance(Duration::from_millis(100));
    rig.round();
    let d = rig.app.device(Address::Pac { axis: Some(2) }).unwrap();
    let why = rig.app.stale(d).expect("axes cannot be read during the drive");
    assert!(why.contains("only polls"), "{why}");
    // Only a stop gets through: any other action is refused before sending.
    rig.keys("e");
    assert!(rig.app.events.back().unwrap().text.contains("nothing was sent"));
    rig.key(KeyCode::Char(' '));
    rig.advance(Duration::from_millis(100));
    rig.round();
    assert_eq!(rig.pac_axis(1).1, 0.0, "the referencing axis stands");
    let d = rig.app.device(Address::Pac { axis: Some(2) }).unwrap();
    assert!(rig.app.stale(d).is_none(), "the line is free again");
}

#[test]
fn cdios_panes() {
    let mut rig = Rig::new();
    rig.round();
    rig.select(Address::Cdios { node: 1, module: 0 });
    rig.keys("eg20000");
    rig.key(KeyCode::Enter);
    rig.advance(Duration::from_millis(200));
    rig.round();
    insta::assert_snapshot!("cdios_moving_80x24", rig.screen(80, 24));
    insta::assert_snapshot!("cdios_moving_200x50", rig.screen(200, 50));
    // An error state: the emergency input stops the motor.
    lock(&rig.bench.cdios).module_mut(0).unwrap().set_emergency(true);
    rig.advance(Duration::from_millis(100));
    rig.round();
    insta::assert_snapshot!("cdios_error_80x24", rig.screen(80, 24));
    let t = rig.terminal(80, 24);
    let (x, y) = Rig::find(&t, "EMERGENCY_INPUT_ACTIVE").unwrap();
    assert_eq!(t.backend().buffer()[(x, y)].fg, Color::Red, "error bits are red");
    // Out of the goto field's range: refused like cdios-goto.
    rig.keys("g3000000000");
    rig.key(KeyCode::Enter);
    assert!(rig.app.events.back().unwrap().text.contains("out of range"), "{:?}", rig.app.events.back());
}

#[test]
fn halt_all_stops_all_three_families_within_one_poll_period() {
    let mut rig = Rig::new();
    rig.everything_moving();
    assert_ne!(rig.cube(3).1, 0.0, "module 3 homing");
    assert_ne!(rig.cube(17).1, 0.0, "module 17 jogging");
    assert_eq!(rig.pac_axis(1).0, 1, "PA axis 1 moving: {:#?}", rig.app.events);
    assert!(rig.cdios_motor(0).0, "Cdios motor 0 running");
    let pac_speed = rig.pac_axis(1).1;
    rig.key(KeyCode::Char(' '));
    // Every device has its stop within one poll period (10 Hz); PowerCube
    // and Cdios stand at once, the PA axis brakes at its acceleration.
    rig.advance(Duration::from_millis(100));
    let failed: Vec<_> = rig.app.events.iter().filter(|e| e.text.contains("failed")).map(|e| &e.text).collect();
    assert!(failed.is_empty(), "{failed:?}");
    let (status, speed) = rig.pac_axis(1);
    assert!(status == 2 || speed < pac_speed, "PA axis 1 braking: status {status}, {speed} < {pac_speed}");
    for m in [3, 5, 17] {
        let (cube, vel) = rig.cube(m);
        assert_ne!(cube & state::HALTED, 0, "module {m} halted");
        assert_eq!(vel, 0.0, "module {m} stands");
    }
    rig.advance(Duration::from_millis(400));
    assert_eq!(rig.pac_axis(1), (2, 0.0), "PA axis 1 stopped");
    let (running, rpm) = rig.cdios_motor(0);
    assert!(!running && rpm == 0.0, "Cdios motor 0 stands: running {running}, {rpm} rpm");
    rig.round();
    insta::assert_snapshot!("after_halt_all_80x24", rig.screen(80, 24));
}

/// The CAN link stops answering while everything moves: halt-all still
/// stops every PowerCube (the broadcast Halt needs no answer) and every
/// Cdios motor (the stop goes out; only its confirmation is lost), and the
/// PA-CONTROL on its own healthy link.
#[test]
fn halt_all_works_while_a_link_times_out() {
    let mut rig = Rig::new();
    rig.everything_moving();
    assert!(rig.cdios_motor(0).0, "Cdios motor 0 running");
    rig.bench.bus.set_fault(Some(Box::new(Silence)));
    rig.advance(Duration::from_millis(100));
    rig.round();
    let d = rig.app.device(Address::PowerCube { module: 3 }).unwrap();
    assert!(rig.app.stale(d).is_some(), "the CAN link is timing out");
    let t0 = rig.clock.now();
    rig.key(KeyCode::Char(' '));
    // The halt itself waits out at most the lost confirmations' timeouts.
    assert!(rig.clock.now() - t0 <= Duration::from_secs(2), "{:?}", rig.clock.now() - t0);
    for m in [3, 5, 17] {
        let (cube, vel) = rig.cube(m);
        assert_ne!(cube & state::HALTED, 0, "module {m} halted");
        assert_eq!(vel, 0.0, "module {m} stands");
    }
    rig.advance(Duration::from_millis(500));
    let (running, rpm) = rig.cdios_motor(0);
    assert!(!running && rpm == 0.0, "Cdios motor 0 stands: running {running}, {rpm} rpm");
    assert_eq!(rig.pac_axis(1), (2, 0.0), "PA axis 1 stopped");
}

/// Every binding of the help does something visible on a device it
/// applies to: a request to a worker, or a change of the screen's state.
#[test]
fn every_key_in_the_help_works() {
    use super::keys::{KeyAction, KEYS};
    for b in KEYS {
        let mut rig = Rig::new();
        rig.round();
        for _ in 0..12 {
            rig.app.log(super::app::Level::Info, "filler so that the event pane can scroll");
        }
        let device = match b.action {
            KeyAction::Enable | KeyAction::Disable => Address::Pac { axis: Some(1) },
            KeyAction::Online | KeyAction::Offline => Address::Pac { axis: None },
            KeyAction::Up => Address::PowerCube { module: 5 },
            _ => Address::PowerCube { module: 3 },
        };
        if matches!(b.action, KeyAction::Enable | KeyAction::Disable | KeyAction::Offline) {
            rig.select(Address::Pac { axis: None });
            rig.keys("o");
            rig.sent.clear();
        }
        rig.select(device);
        if b.action == KeyAction::ScrollDown {
            rig.key(KeyCode::PageUp);
        }
        let state = |app: &App| {
            let views = (app.chart, app.overview, app.snapshot.clone());
            (app.selected, app.mode.clone(), app.jog, app.rate, app.scroll, views)
        };
        let before = state(&rig.app);
        rig.key(b.codes[0]);
        let after = state(&rig.app);
        let did = !rig.sent.is_empty() || before != after || rig.app.quit;
        assert!(did, "{} ({:?}) did nothing on {:?}", b.keys, b.action, device);
        if let Some(e) = rig.app.events.iter().find(|e| e.level == super::app::Level::Error) {
            panic!("{} ({:?}) on {:?}: {}", b.keys, b.action, device, e.text);
        }
    }
}

/// docs/guide.md carries the key table exactly as the code declares it.
#[test]
fn the_guide_lists_the_keys_of_the_code() {
    let guide = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/docs/guide.md")).unwrap();
    let table = super::keys::markdown_table();
    assert!(guide.contains(&table), "docs/guide.md must contain the key table of src/tui/keys.rs:\n{table}");
}

/// `pac-auto-start` (0602) from another session, then space: halt-all reads
/// the mode fresh and sends STOP (0600), which a cached "home position"
/// would have skipped.
#[test]
fn halt_all_stops_a_pac_in_automatic_mode() {
    let mut rig = Rig::new();
    rig.round();
    let shared: Arc<dyn Clock> = Arc::new(rig.clock.clone());
    let link = Box::new(rig.bench.pac_link(Arc::clone(&shared)));
    let mut cli = crate::device::pac::Controller::new(Pac::new(link, 9600, SerialFormat::F7N1).with_clock(shared));
    cli.send(0x0602, 0, None).expect("pac-auto-start");
    assert_eq!(lock(&rig.bench.pac).status(), 11, "automatic mode runs");
    rig.key(KeyCode::Char(' '));
    assert_eq!(lock(&rig.bench.pac).status(), 15, "automatic mode stopped by 0600: {:#?}", rig.app.events);
    let texts: Vec<_> = rig.app.events.iter().map(|e| e.text.as_str()).collect();
    assert!(texts.iter().any(|t| t.contains("STOP (0600) sent")), "{texts:#?}");
    // Stopped means stopped: the program's output stands from now on.
    let output = lock(&rig.bench.pac).output(16);
    rig.advance(Duration::from_secs(3));
    rig.round();
    let mut pac = lock(&rig.bench.pac);
    pac.advance(rig.clock.now());
    assert_eq!(pac.output(16), output, "the automatic program no longer runs");
}

/// A flapping CAN link (answers, then nothing, again and again): each
/// device's "no answer" and "answers again" stay one line each, with a count.
#[test]
fn a_flapping_link_folds_its_events_with_a_count() {
    let mut rig = Rig::new();
    rig.round();
    let before = rig.app.events.len();
    for _ in 0..10 {
        rig.bench.bus.set_fault(Some(Box::new(Silence)));
        rig.advance(Duration::from_millis(100));
        rig.round();
        rig.bench.bus.set_fault(None);
        rig.advance(Duration::from_millis(100));
        rig.round();
    }
    let lines: Vec<_> = rig.app.events.iter().skip(before).collect();
    let cube = Address::PowerCube { module: 3 }.label();
    let again: Vec<_> = lines.iter().filter(|e| e.text == format!("{cube}: answers again")).collect();
    assert_eq!(again.len(), 1, "{lines:?}");
    assert_eq!(again[0].count, 10);
    assert!(again[0].shown().ends_with("(×10)"), "{}", again[0].shown());
    let lost: Vec<_> = lines.iter().filter(|e| e.text.starts_with(&format!("{cube}: ")) && e.count == 10).collect();
    assert_eq!(lost.len(), 2, "no answer and answers again, ten times each: {lines:?}");
    assert_eq!(lines.len(), 10, "one pair of lines per flapping device (3 PowerCubes, 2 Cdios): {lines:?}");
}

/// SIGTERM / SIGHUP: the axis this dashboard set moving is halted before the
/// workers quit; a module it did not move is left alone, as `q` leaves it.
#[test]
fn terminate_halts_what_the_dashboard_moved_then_quits() {
    let mut rig = Rig::new();
    rig.round();
    rig.select(Address::PowerCube { module: 17 });
    rig.key(KeyCode::Char('g'));
    rig.keys("0.5");
    rig.key(KeyCode::Enter);
    rig.advance(Duration::from_millis(300));
    rig.round();
    assert_ne!(rig.cube(17).1, 0.0, "module 17 moving");
    assert_eq!(rig.app.moved, [(0, Address::PowerCube { module: 17 })]);
    let outs = rig.app.handle(Event::Terminate(libc::SIGTERM));
    assert!(rig.app.quit);
    let msgs: Vec<_> = outs.iter().filter(|o| o.link == 0).map(|o| o.msg.clone()).collect();
    assert_eq!(msgs, [ToWorker::Act(Address::PowerCube { module: 17 }, super::source::Action::Halt), ToWorker::Quit]);
    let mut events = Vec::new();
    assert!(rig.workers[0].handle(msgs, &mut |ev| events.push(ev)), "the worker quits after the halt");
    let (cube, vel) = rig.cube(17);
    assert_ne!(cube & state::HALTED, 0, "module 17 halted");
    assert_eq!(vel, 0.0);
    assert!(rig.app.events.iter().any(|e| e.text.starts_with("SIGTERM: halting")), "{:?}", rig.app.events);
}

/// A jog is a motion like home and go to: the App and the worker each keep
/// the jogged module, SIGTERM and SIGHUP halt it, and actions that move
/// nothing (a halt, a reset, enable) are not kept.
#[test]
fn terminate_halts_a_jog_the_dashboard_started() {
    for (signal, name) in [(libc::SIGTERM, "SIGTERM"), (libc::SIGHUP, "SIGHUP")] {
        let mut rig = Rig::new();
        rig.round();
        rig.select(Address::PowerCube { module: 5 });
        rig.keys("s");
        rig.keys("r");
        rig.select(Address::Cdios { node: 1, module: 0 });
        rig.keys("e");
        rig.select(Address::PowerCube { module: 17 });
        rig.keys("]]+");
        rig.keys("+");
        rig.advance(Duration::from_millis(300));
        rig.round();
        assert_ne!(rig.cube(17).1, 0.0, "{name}: module 17 jogging");
        assert_eq!(
            rig.app.moved,
            [(0, Address::PowerCube { module: 17 })],
            "{name}: the App keeps the jog once, and only it"
        );
        assert_eq!(rig.workers[0].moved(), [Address::PowerCube { module: 17 }], "{name}: so does the worker");
        let outs = rig.app.handle(Event::Terminate(signal));
        assert!(rig.app.quit);
        let msgs: Vec<_> = outs.iter().filter(|o| o.link == 0).map(|o| o.msg.clone()).collect();
        assert_eq!(
            msgs,
            [ToWorker::Act(Address::PowerCube { module: 17 }, super::source::Action::Halt), ToWorker::Quit]
        );
        let mut events = Vec::new();
        assert!(rig.workers[0].handle(msgs, &mut |ev| events.push(ev)), "the worker quits after the halt");
        let (cube, vel) = rig.cube(17);
        assert_ne!(cube & state::HALTED, 0, "{name}: module 17 halted");
        assert_eq!(vel, 0.0, "{name}: module 17 stands");
        let halting = format!("{name}: halting");
        assert!(rig.app.events.iter().any(|e| e.text.starts_with(&halting)), "{:?}", rig.app.events);
    }
}

/// A terminal that reports key releases (Windows, or the kitty keyboard
/// protocol) sends a press and a release for each stroke: only the press
/// acts, or one stroke of a jog key would jog twice.
#[test]
fn a_key_release_acts_on_nothing() {
    let mut rig = Rig::new();
    rig.round();
    rig.select(Address::PowerCube { module: 17 });
    let release = |c| Event::Key(KeyEvent::new_with_kind(KeyCode::Char(c), KeyModifiers::NONE, KeyEventKind::Release));
    for c in ['+', 'g', 'h', 'q'] {
        assert!(rig.app.handle(release(c)).is_empty(), "the release of {c:?} asked the workers for something");
    }
    assert_eq!(rig.app.mode, Mode::Normal, "a release opens no prompt");
    assert!(!rig.app.quit && rig.app.moved.is_empty());
    let press = rig.app.handle(Event::Key(KeyEvent::new(KeyCode::Char('+'), KeyModifiers::NONE)));
    assert!(
        matches!(
            press[..],
            [super::app::Outgoing {
                msg: ToWorker::Act(Address::PowerCube { module: 17 }, super::source::Action::Jog(_)),
                ..
            }]
        ),
        "the press jogs once"
    );
}

/// The worker's own list (what it halts when it panics) keeps a jog.
#[test]
fn a_worker_halts_the_jog_it_sent_on_its_own() {
    let mut rig = Rig::new();
    rig.round();
    rig.select(Address::PowerCube { module: 3 });
    rig.keys("s");
    rig.select(Address::PowerCube { module: 17 });
    rig.keys("]]+");
    rig.advance(Duration::from_millis(300));
    rig.round();
    assert_ne!(rig.cube(17).1, 0.0, "module 17 jogging");
    assert_eq!(rig.workers[0].halt_moved(), "halted PowerCube 17");
    let (cube, vel) = rig.cube(17);
    assert_ne!(cube & state::HALTED, 0, "module 17 halted");
    assert_eq!(vel, 0.0, "module 17 stands");
}

/// A device the worker's scan did not list (a module that missed a
/// rescan) is still served, and halted, by the source of its family, not
/// by another family's source on the same link.
#[test]
fn a_device_the_scan_did_not_list_is_served_by_its_familys_source() {
    let rig = Rig::new();
    let shared: Arc<dyn Clock> = Arc::new(rig.clock.clone());
    let can = CanBus::new(Box::new(rig.bench.bus.open()), Arc::clone(&shared));
    let cube: Box<dyn DeviceSource> = Box::new(CubeSource::new(
        PowerCube::over_can(Box::new(can.port(Family::PowerCube))).with_clock(Arc::clone(&shared)),
        None,
    ));
    let cdios: Box<dyn DeviceSource> = Box::new(CdiosSource::new(
        Cdios::new(Box::new(can.port(Family::Cdios))).with_clock(Arc::clone(&shared)),
        NodeId::new(1).unwrap(),
        None,
        RetryPolicy::default(),
    ));
    // Never scanned: no device is listed.
    let mut worker = LinkWorker::new(0, vec![cube, cdios], Arc::clone(&shared), 10.0);
    let mut said = Vec::new();
    let jog = ToWorker::Act(Address::PowerCube { module: 17 }, super::source::Action::Jog(0.1));
    worker.handle(vec![jog], &mut |ev| said.push(ev));
    assert!(matches!(&said[..], [LinkEvent::Acted { result: Ok(_), .. }]), "{said:?}");
    rig.clock.advance(Duration::from_millis(300));
    lock(&rig.bench.powercube).advance(rig.clock.now());
    assert_ne!(rig.cube(17).1, 0.0, "module 17 jogging");
    assert_eq!(worker.halt_moved(), "halted PowerCube 17");
    let (cube, vel) = rig.cube(17);
    assert_ne!(cube & state::HALTED, 0, "module 17 halted");
    assert_eq!(vel, 0.0, "module 17 stands");
}

/// The dashboard's CAN link, losing every PowerCube broadcast it sends.
struct LoseBroadcasts {
    inner: Box<dyn CanLink>,
    lost: Arc<std::sync::atomic::AtomicUsize>,
}

impl CanLink for LoseBroadcasts {
    fn send(&mut self, frame: &CanFrame) -> Result<(), LinkError> {
        if frame.id() == crate::proto::powercube::can::BROADCAST_ID {
            self.lost.fetch_add(1, std::sync::atomic::Ordering::SeqCst);
            return Ok(());
        }
        self.inner.send(frame)
    }
    fn recv(&mut self, timeout: Duration) -> Result<Option<CanFrame>, LinkError> {
        self.inner.recv(timeout)
    }
}

/// Halt-all sends each known module its own Halt after the broadcast: a
/// module that missed the broadcast (here every one: the link loses it) is
/// still halted, moving or not.
#[test]
fn halt_all_halts_each_module_when_the_broadcast_is_lost() {
    let lost = Arc::new(std::sync::atomic::AtomicUsize::new(0));
    let counter = Arc::clone(&lost);
    let mut rig = Rig::with_can(move |inner| Box::new(LoseBroadcasts { inner, lost: counter }));
    rig.round();
    rig.select(Address::PowerCube { module: 3 });
    rig.keys("h");
    rig.select(Address::PowerCube { module: 17 });
    rig.keys("]]+");
    rig.advance(Duration::from_millis(300));
    rig.round();
    assert_ne!(rig.cube(3).1, 0.0, "module 3 homing");
    assert_ne!(rig.cube(17).1, 0.0, "module 17 jogging");
    rig.key(KeyCode::Char(' '));
    assert!(lost.load(std::sync::atomic::Ordering::SeqCst) > 0, "the broadcast Halt was sent, and lost");
    for m in [3, 5, 17] {
        let (cube, vel) = rig.cube(m);
        assert_ne!(cube & state::HALTED, 0, "module {m} halted");
        assert_eq!(vel, 0.0, "module {m} stands");
    }
}

/// The CAN sources of the contract bench on a fresh link of its bus.
fn can_sources(bus: &crate::link::mem::MemBus, clock: &Arc<dyn Clock>) -> Vec<Box<dyn DeviceSource>> {
    let can = CanBus::new(Box::new(bus.open()), Arc::clone(clock));
    vec![Box::new(CubeSource::new(
        PowerCube::over_can(Box::new(can.port(Family::PowerCube))).with_clock(Arc::clone(clock)),
        None,
    ))]
}

/// The adapter goes away: after a few silent rounds the worker closes the
/// link (its sources, which own it, are dropped), tries again with backoff,
/// and once the link answers again the devices come back by themselves.
#[test]
fn a_lost_link_is_closed_reopened_with_backoff_and_its_devices_come_back() {
    let mut rig = Rig::new();
    let shared: Arc<dyn Clock> = Arc::new(rig.clock.clone());
    let bus = rig.bench.bus.clone();
    let opens = Arc::new(std::sync::atomic::AtomicUsize::new(0));
    let (count, reopen_clock) = (Arc::clone(&opens), Arc::clone(&shared));
    let fail = Arc::new(std::sync::atomic::AtomicBool::new(true));
    let failing = Arc::clone(&fail);
    let worker =
        LinkWorker::new(0, can_sources(&bus, &shared), Arc::clone(&shared), 10.0).with_reopen(Box::new(move || {
            count.fetch_add(1, std::sync::atomic::Ordering::SeqCst);
            if failing.load(std::sync::atomic::Ordering::SeqCst) {
                return Err("no such device".into());
            }
            Ok(can_sources(&bus, &reopen_clock))
        }));
    rig.workers[0] = worker;
    let ev = rig.workers[0].discover();
    rig.feed(ev);
    rig.round();
    assert!(rig.app.stale(rig.app.device(Address::PowerCube { module: 3 }).unwrap()).is_none());
    rig.bench.bus.set_fault(Some(Box::new(Silence)));
    for _ in 0..super::worker::DOWN_AFTER {
        rig.advance(Duration::from_millis(100));
        rig.round();
    }
    assert!(rig.workers[0].is_down(), "{:?}", rig.app.events);
    assert!(rig.app.events.iter().any(|e| e.text.contains("link lost")), "{:?}", rig.app.events);
    // A rescan while the link is closed scans nothing and says nothing, so
    // the App keeps listing what was lost.
    let mut said = Vec::new();
    assert!(!rig.workers[0].handle(vec![ToWorker::Rescan], &mut |ev| said.push(ev)));
    assert!(said.is_empty(), "{said:?}");
    // Backoff: no try before BACKOFF_MIN, then one failing try, then a longer wait.
    rig.round();
    assert_eq!(opens.load(std::sync::atomic::Ordering::SeqCst), 0);
    rig.advance(super::worker::BACKOFF_MIN);
    rig.round();
    assert_eq!(opens.load(std::sync::atomic::Ordering::SeqCst), 1);
    rig.advance(super::worker::BACKOFF_MIN);
    rig.round();
    assert_eq!(opens.load(std::sync::atomic::Ordering::SeqCst), 1, "the wait doubled");
    // The adapter is back, the modules still silent during its scan: they
    // are polled all the same, and answer a moment later.
    fail.store(false, std::sync::atomic::Ordering::SeqCst);
    rig.advance(super::worker::BACKOFF_MIN * 2);
    rig.round();
    assert_eq!(opens.load(std::sync::atomic::Ordering::SeqCst), 2);
    assert!(!rig.workers[0].is_down());
    rig.bench.bus.set_fault(None);
    rig.advance(Duration::from_millis(100));
    rig.round();
    let d = rig.app.device(Address::PowerCube { module: 3 }).unwrap();
    assert!(rig.app.stale(d).is_none(), "module 3 current again: {:?}", rig.app.events);
    assert!(rig.app.events.iter().any(|e| e.text.ends_with("reopened")), "{:?}", rig.app.events);
}

/// A module that missed the start-up scan is found by the rescan key.
#[test]
fn rescan_finds_a_module_missing_at_start() {
    let mut rig = Rig::new();
    let shared: Arc<dyn Clock> = Arc::new(rig.clock.clone());
    // The CAN bus says nothing during the start-up scan.
    rig.bench.bus.set_fault(Some(Box::new(Silence)));
    rig.workers[0] = LinkWorker::new(0, can_sources(&rig.bench.bus.clone(), &shared), shared, 10.0);
    rig.app.devices.clear();
    let ev = rig.workers[0].discover();
    rig.feed(ev);
    assert!(!rig.app.devices.iter().any(|d| d.key == Address::PowerCube { module: 17 }));
    rig.bench.bus.set_fault(None);
    rig.keys("n");
    assert!(rig.sent.contains(&ToWorker::Rescan));
    assert!(rig.app.devices.iter().any(|d| d.key == Address::PowerCube { module: 17 }), "found by the rescan");
    assert!(rig.app.events.iter().any(|e| e.text == "rescan sent to every link"));
}

/// A terminal whose draws fail (`1`: an error, as a closed terminal gives)
/// or panic (`2`) from the moment the test says so.
struct Flaky {
    inner: TestBackend,
    mode: Arc<std::sync::atomic::AtomicU8>,
}

impl ratatui::backend::Backend for Flaky {
    type Error = std::io::Error;
    fn draw<'a, I>(&mut self, content: I) -> Result<(), Self::Error>
    where
        I: Iterator<Item = (u16, u16, &'a ratatui::buffer::Cell)>,
    {
        match self.mode.load(std::sync::atomic::Ordering::SeqCst) {
            1 => Err(std::io::Error::other("terminal gone")),
            2 => panic!("injected draw panic"),
            _ => self.inner.draw(content).map_err(|e| match e {}),
        }
    }
    fn hide_cursor(&mut self) -> Result<(), Self::Error> {
        self.inner.hide_cursor().map_err(|e| match e {})
    }
    fn show_cursor(&mut self) -> Result<(), Self::Error> {
        self.inner.show_cursor().map_err(|e| match e {})
    }
    fn get_cursor_position(&mut self) -> Result<ratatui::layout::Position, Self::Error> {
        self.inner.get_cursor_position().map_err(|e| match e {})
    }
    fn set_cursor_position<P: Into<ratatui::layout::Position>>(&mut self, position: P) -> Result<(), Self::Error> {
        self.inner.set_cursor_position(position).map_err(|e| match e {})
    }
    fn clear(&mut self) -> Result<(), Self::Error> {
        self.inner.clear().map_err(|e| match e {})
    }
    fn clear_region(&mut self, clear_type: ratatui::backend::ClearType) -> Result<(), Self::Error> {
        self.inner.clear_region(clear_type).map_err(|e| match e {})
    }
    fn size(&self) -> Result<ratatui::layout::Size, Self::Error> {
        self.inner.size().map_err(|e| match e {})
    }
    fn window_size(&mut self) -> Result<ratatui::backend::WindowSize, Self::Error> {
        self.inner.window_size().map_err(|e| match e {})
    }
    fn flush(&mut self) -> Result<(), Self::Error> {
        self.inner.flush().map_err(|e| match e {})
    }
}

/// A PowerCube source whose polls panic from the moment the test says so.
struct Panicky {
    inner: CubeSource,
    armed: Arc<std::sync::atomic::AtomicBool>,
}

impl DeviceSource for Panicky {
    fn family(&self) -> Family {
        self.inner.family()
    }
    fn discover(&mut self) -> Result<Vec<Address>, super::source::SourceError> {
        self.inner.discover()
    }
    fn poll(&mut self, dev: Address) -> Result<Snapshot, super::source::SourceError> {
        if self.armed.load(std::sync::atomic::Ordering::SeqCst) {
            panic!("injected worker panic");
        }
        self.inner.poll(dev)
    }
    fn act(&mut self, dev: Address, action: super::source::Action) -> Result<String, super::source::SourceError> {
        self.inner.act(dev, action)
    }
    fn halt_all(&mut self) -> Vec<super::source::HaltReport> {
        self.inner.halt_all()
    }
    fn face(&mut self) -> &mut dyn crate::device::face::Face {
        self.inner.face()
    }
}

/// The real UI loop on real time: module 17 (linear, slow: 0.5 m takes
/// seconds) on link 0 through a source that can be made to panic, module 3
/// on link 1. Both are sent moving with keys, then `hit` breaks something.
struct Live {
    bench: Bench,
    clock: Arc<dyn Clock>,
    mode: Arc<std::sync::atomic::AtomicU8>,
    worker_panics: Arc<std::sync::atomic::AtomicBool>,
    /// Where `p` writes its charts.
    snapshots: std::path::PathBuf,
    _dir: tempfile::TempDir,
}

impl Live {
    fn new() -> Self {
        let clock: Arc<dyn Clock> = Arc::new(crate::clock::SystemClock);
        let dir = tempfile::tempdir().unwrap();
        Self {
            bench: Bench::contract(Arc::clone(&clock)),
            clock,
            mode: Arc::new(std::sync::atomic::AtomicU8::new(0)),
            worker_panics: Arc::new(std::sync::atomic::AtomicBool::new(false)),
            snapshots: dir.path().to_path_buf(),
            _dir: dir,
        }
    }

    fn source(&self, m: u8) -> CubeSource {
        let pc = PowerCube::over_can(Box::new(self.bench.bus.open())).with_clock(Arc::clone(&self.clock));
        CubeSource::new(pc, Some(vec![crate::proto::powercube::ModuleId::new(m).unwrap()]))
    }

    fn cube(&self, id: u8) -> (u32, f32) {
        let mut pc = lock(&self.bench.powercube);
        pc.advance(self.clock.now());
        let m = pc.module(id).unwrap();
        (m.cube_state(), m.velocity())
    }

    /// Runs the dashboard until it ends; `hit` is called once both modules
    /// move, and returns whether both did. A dashboard that does not end on
    /// the hit is told `q` after 5 s, so a regression fails instead of hangs.
    fn run(&self, hit: impl FnOnce(&Self) + Send) -> (anyhow::Result<()>, bool) {
        self.run_moving_17_with("g0.5\n", hit)
    }

    /// [`Live::run`], module 17 sent moving by the keys `keys17` (a newline
    /// presses Enter) instead of a go to 0.5.
    fn run_moving_17_with(&self, keys17: &str, hit: impl FnOnce(&Self) + Send) -> (anyhow::Result<()>, bool) {
        let plans = vec![
            super::LinkPlan {
                name: "can A".into(),
                sources: vec![Box::new(Panicky { inner: self.source(17), armed: Arc::clone(&self.worker_panics) })],
                reopen: None,
            },
            super::LinkPlan { name: "can B".into(), sources: vec![Box::new(self.source(3))], reopen: None },
        ];
        let mut terminal =
            Terminal::new(Flaky { inner: TestBackend::new(100, 30), mode: Arc::clone(&self.mode) }).unwrap();
        let moving = std::sync::atomic::AtomicBool::new(false);
        let r = std::thread::scope(|scope| {
            let (key_tx, key_rx) = std::sync::mpsc::channel::<std::sync::mpsc::Sender<Event>>();
            let moving = &moving;
            scope.spawn(move || {
                let Ok(tx) = key_rx.recv() else { return };
                let press = |code| {
                    let _ = tx.send(Event::Key(KeyEvent::new(code, KeyModifiers::NONE)));
                    std::thread::sleep(Duration::from_millis(30));
                };
                // Discovery first; then module 17 to 0.5, module 3 to 1.0.
                std::thread::sleep(Duration::from_millis(500));
                let keys17 = keys17.chars().map(|c| if c == '\n' { KeyCode::Enter } else { KeyCode::Char(c) });
                for code in keys17.chain([KeyCode::Down]) {
                    press(code);
                }
                for code in "g1.0".chars().map(KeyCode::Char).chain([KeyCode::Enter]) {
                    press(code);
                }
                // A loaded machine may take a while to carry the keys out.
                for _ in 0..60 {
                    std::thread::sleep(Duration::from_millis(50));
                    if self.cube(17).1 != 0.0 && self.cube(3).1 != 0.0 {
                        moving.store(true, std::sync::atomic::Ordering::SeqCst);
                        break;
                    }
                }
                hit(self);
                for _ in 0..100 {
                    std::thread::sleep(Duration::from_millis(50));
                    if tx.send(Event::Tick(self.clock.now())).is_err() {
                        return;
                    }
                }
                press(KeyCode::Char('q'));
            });
            super::run_with_keys(&mut terminal, plans, 10.0, &self.snapshots, Arc::clone(&self.clock), move |tx| {
                let _ = key_tx.send(tx);
                Ok(())
            })
        });
        (r, moving.load(std::sync::atomic::Ordering::SeqCst))
    }

    fn assert_both_halted(&self) {
        for m in [17, 3] {
            let (cube, vel) = self.cube(m);
            assert_ne!(cube & state::HALTED, 0, "module {m} halted");
            assert_eq!(vel, 0.0, "module {m} stands");
        }
    }
}

/// The terminal cannot be written any more (a draw fails with no signal on
/// the way): nobody sees the screen, so what the dashboard moved is halted
/// before it quits, and the error says so.
#[test]
fn a_failed_draw_halts_what_the_dashboard_moved() {
    let live = Live::new();
    let (r, moving) = live.run(|l| l.mode.store(1, std::sync::atomic::Ordering::SeqCst));
    assert!(moving, "both modules were moving");
    let e = r.expect_err("a failed draw ends the dashboard");
    assert_eq!(e.to_string(), "the screen cannot be drawn (terminal gone): halted what the dashboard moved and quit");
    assert!(e.downcast_ref::<super::Stopped>().is_some());
    live.assert_both_halted();
}

/// A panic in a draw (the UI thread): the unwind guard halts what the
/// dashboard moved, then the panic goes on.
#[test]
fn a_panic_in_a_draw_halts_what_the_dashboard_moved() {
    let live = Live::new();
    let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        live.run(|l| l.mode.store(2, std::sync::atomic::Ordering::SeqCst))
    }));
    let payload = r.expect_err("the panic goes on after the halt");
    assert_eq!(super::worker::panic_text(payload.as_ref()), "injected draw panic");
    live.assert_both_halted();
}

/// A worker panics: it halts what it moved (module 17, on its own link)
/// with the sources it still holds, and the UI halts the rest (module 3,
/// on the other link) and quits.
#[test]
fn a_worker_panic_halts_what_the_dashboard_moved() {
    let live = Live::new();
    let (r, moving) = live.run(|l| l.worker_panics.store(true, std::sync::atomic::Ordering::SeqCst));
    assert!(moving, "both modules were moving");
    let e = r.expect_err("a worker panic ends the dashboard");
    assert_eq!(
        e.to_string(),
        "the worker of link 0 panicked (injected worker panic; halted PowerCube 17): halted what the dashboard \
         moved and quit"
    );
    live.assert_both_halted();
}

/// The same with a jog as module 17's motion: the worker halts the jog.
#[test]
fn a_worker_panic_halts_a_jog_the_dashboard_started() {
    let live = Live::new();
    let (r, moving) =
        live.run_moving_17_with("]]+", |l| l.worker_panics.store(true, std::sync::atomic::Ordering::SeqCst));
    assert!(moving, "both modules were moving");
    let e = r.expect_err("a worker panic ends the dashboard");
    assert_eq!(
        e.to_string(),
        "the worker of link 0 panicked (injected worker panic; halted PowerCube 17): halted what the dashboard \
         moved and quit"
    );
    live.assert_both_halted();
}

impl Rig {
    /// Every family moving, polled every 100 ms for `rounds` rounds.
    fn moving_for(&mut self, rounds: u32) {
        self.everything_moving();
        for _ in 0..rounds {
            self.advance(Duration::from_millis(100));
            self.round();
        }
    }
}

/// Cells of the screen drawn with braille dots (the chart's lines).
fn braille_cells(t: &Terminal<TestBackend>) -> usize {
    t.backend()
        .buffer()
        .content
        .iter()
        .filter(|c| c.symbol().chars().any(|ch| ('\u{2801}'..='\u{28ff}').contains(&ch)))
        .count()
}

/// `v`: one table with every device of the three families, position,
/// velocity and current in the device's units, and the state word.
#[test]
fn overview_shows_the_whole_bench_with_units() {
    let mut rig = Rig::new();
    rig.moving_for(10);
    rig.select(Address::PowerCube { module: 17 });
    rig.keys("v");
    assert!(rig.app.overview);
    for (w, h) in [(80, 24), (200, 50)] {
        let screen = rig.screen(w, h);
        for d in &rig.app.devices {
            assert!(screen.contains(&d.key.label()), "{} missing at {w}x{h}:\n{screen}", d.key.label());
        }
        for unit in [" rad ", " rad/s", " m ", " m/s", " A ", " AE ", " AE/s", " counts", " rpm"] {
            assert!(screen.contains(unit), "no {unit:?} at {w}x{h}:\n{screen}");
        }
        for word in ["moving", "online", "off"] {
            assert!(screen.contains(word), "no state {word:?} at {w}x{h}:\n{screen}");
        }
    }
    insta::assert_snapshot!("overview_80x24", rig.screen(80, 24));
    insta::assert_snapshot!("overview_200x50", rig.screen(200, 50));
    // Actions still act on the selected row.
    rig.keys("s");
    assert!(rig.sent.contains(&ToWorker::Act(Address::PowerCube { module: 17 }, super::source::Action::Halt)));
    rig.keys("v");
    assert!(!rig.app.overview);
    assert!(rig.screen(80, 24).contains("Devices"));
}

/// `c`: the selected device's position, velocity and current, each on its
/// own axis with its unit, drawn from the polls of the last 30 s.
#[test]
fn chart_shows_the_motion_of_the_selected_device() {
    let mut rig = Rig::new();
    rig.moving_for(20);
    rig.select(Address::PowerCube { module: 17 });
    let plain = rig.terminal(80, 24);
    assert_eq!(braille_cells(&plain), 0);
    rig.keys("c");
    assert!(rig.app.chart);
    for (w, h) in [(80, 24), (200, 50)] {
        let t = rig.terminal(w, h);
        let screen = t.backend().to_string();
        for name in ["position", "velocity", "current", " m/s", "last 30 s"] {
            assert!(screen.contains(name), "no {name:?} at {w}x{h}:\n{screen}");
        }
        assert!(braille_cells(&t) > 20, "no chart lines at {w}x{h}:\n{screen}");
    }
    assert!(rig.screen(200, 50).contains("-30 s"), "the time axis is labelled when there is room");
    insta::assert_snapshot!("chart_80x24", rig.screen(80, 24));
    insta::assert_snapshot!("chart_200x50", rig.screen(200, 50));
    // A PA axis and a Cdios module have no current: two plots.
    rig.select(Address::Pac { axis: Some(1) });
    let screen = rig.screen(80, 24);
    assert!(screen.contains("AE/s") && !screen.contains("current"), "{screen}");
    rig.select(Address::Cdios { node: 1, module: 0 });
    let screen = rig.screen(80, 24);
    assert!(screen.contains("rpm") && screen.contains("counts"), "{screen}");
    // The controller line has no motion values, and says so.
    rig.select(Address::Pac { axis: None });
    assert!(rig.screen(80, 24).contains("no motion values to chart"));
    // Overview and chart together.
    rig.select(Address::PowerCube { module: 17 });
    rig.keys("v");
    insta::assert_snapshot!("overview_chart_80x24", rig.screen(80, 24));
    insta::assert_snapshot!("overview_chart_200x50", rig.screen(200, 50));
    rig.keys("c");
    assert!(!rig.app.chart);
}

fn axis_poll(link: usize, axis: u8, at: std::time::Instant, position: f64) -> Event {
    let snap = PacAxisSnap { position, speed: 1.0, status: 1, ext_status: 0x0101_0101, min_pos: None, max_pos: None };
    Event::Link(LinkEvent::Polled {
        link,
        device: Address::Pac { axis: Some(axis) },
        at,
        result: Ok(Snapshot::new(snap)),
        health: super::source::Health::Answer,
    })
}

/// The history is pure App state: 30 s of polls, never more than
/// CAPACITY samples whatever the rate and however long it runs.
#[test]
fn history_keeps_30_s_in_a_bounded_ring() {
    use super::history::{CAPACITY, WINDOW};
    let t0 = std::time::Instant::now();
    let mut app = App::new(vec![LinkView::new("l", vec![Family::Pac], 10.0)], 10.0, t0);
    app.handle(Event::Link(LinkEvent::Discovered {
        link: 0,
        devices: vec![Address::Pac { axis: Some(1) }, Address::Pac { axis: Some(2) }],
        errors: vec![],
    }));
    // Axis 1 at 10 Hz for 2 minutes: the last 30 s stay (and the one sample
    // before them, where the line enters the chart).
    for i in 0..1200u64 {
        app.handle(axis_poll(0, 1, t0 + Duration::from_millis(100 * i), i as f64));
    }
    let now = t0 + Duration::from_millis(100 * 1199);
    let h = &app.device(Address::Pac { axis: Some(1) }).unwrap().history;
    assert_eq!(h.len(), 302, "30 s at 10 Hz, both ends, and one before");
    let oldest = h.samples().next().unwrap();
    assert!(now.duration_since(oldest.at) > WINDOW);
    assert!(now.duration_since(h.samples().nth(1).unwrap().at) <= WINDOW);
    // Axis 2 at 1 kHz, ten times the fastest poll rate, for 60 s: bounded.
    let t1 = now;
    for i in 0..60_000u64 {
        app.handle(axis_poll(0, 2, t1 + Duration::from_millis(i), i as f64));
        if i % 10_000 == 0 {
            assert!(app.device(Address::Pac { axis: Some(2) }).unwrap().history.len() <= CAPACITY);
        }
    }
    assert_eq!(app.device(Address::Pac { axis: Some(2) }).unwrap().history.len(), CAPACITY);
    // A report older than the newest sample (a clock step) is not charted.
    app.handle(axis_poll(0, 2, t1, -1.0));
    let h = &app.device(Address::Pac { axis: Some(2) }).unwrap().history;
    assert!(h.samples().all(|s| s.pos >= 0.0));
    // The chart's traces: x within the window before now, newest at 0.
    app.handle(Event::Tick(t1 + Duration::from_millis(59_999)));
    app.selected = 1;
    let req = app.chart_of(app.selected().unwrap()).unwrap();
    let names: Vec<_> = req.traces.iter().map(|t| (t.name, t.unit)).collect();
    assert_eq!(names, [("position", "AE"), ("velocity", "AE/s")]);
    let xs: Vec<f64> = req.traces[0].points.iter().map(|p| p.0).collect();
    assert_eq!(*xs.last().unwrap(), 0.0);
    assert!(xs.iter().all(|x| (-31.0..=0.0).contains(x)), "{:?}", &xs[..3]);
    // At 1 kHz the ring holds the last 3 s; thinned for drawing to at most
    // two points per column, the extremes kept.
    assert!(xs[0] > -3.1, "{}", xs[0]);
    let points = &req.traces[0].points;
    let thin = super::history::thin(points, 50);
    assert!(thin.len() <= 100, "{}", thin.len());
    assert_eq!((thin.first(), thin.last()), (points.first(), points.last()));
    let axis1 = app.device(Address::Pac { axis: Some(1) }).unwrap().history.traces(
        super::history::motion(app.device(Address::Pac { axis: Some(1) }).unwrap().snap.as_ref().unwrap()).unwrap().0,
        now,
    );
    let thin = super::history::thin(&axis1[0].points, 50);
    assert!((50..=100).contains(&thin.len()), "{}", thin.len());
}

/// `c` and `v` toggle the views, `p` asks for the selected device's
/// chart (and only for a device with motion values); none of them sends
/// anything to a worker.
#[test]
fn chart_overview_and_snapshot_keys() {
    let mut rig = Rig::new();
    rig.moving_for(5);
    rig.sent.clear();
    rig.select(Address::PowerCube { module: 3 });
    rig.keys("cv");
    assert!(rig.app.chart && rig.app.overview);
    rig.keys("cv");
    assert!(!rig.app.chart && !rig.app.overview);
    rig.keys("p");
    let req = rig.app.snapshot.take().expect("a chart to write");
    assert_eq!(req.device, Address::PowerCube { module: 3 });
    let names: Vec<_> = req.traces.iter().map(|t| (t.name, t.unit)).collect();
    assert_eq!(names, [("position", "rad"), ("velocity", "rad/s"), ("current", "A")]);
    assert!(req.traces.iter().all(|t| t.points.len() >= 5), "{req:?}");
    rig.select(Address::Pac { axis: None });
    rig.keys("p");
    assert!(rig.app.snapshot.is_none());
    assert!(rig.app.events.iter().any(|e| e.text == "PA-CONTROL: no motion values to chart"));
    assert!(rig.sent.is_empty(), "{:?}", rig.sent);
    // The loop's answer lands in the events and, for a while, the status bar.
    rig.app.handle(Event::Saved(Ok("./axisctl-chart-powercube-3-x.svg".into())));
    assert!(rig.screen(80, 24).contains("chart written to ./axisctl-chart-powercube-3-x.svg"));
    assert_eq!(rig.screen(80, 24).matches("chart written to").count(), 2, "in the events and the status bar");
    rig.advance(super::app::NOTICE);
    assert_eq!(rig.screen(80, 24).matches("chart written to").count(), 1, "the notice goes away");
    assert!(rig.app.events.iter().any(|e| e.text == "chart written to ./axisctl-chart-powercube-3-x.svg"));
}

/// Whether every element of an SVG document is closed, in order.
fn well_formed(svg: &str) -> Result<(), String> {
    let mut open: Vec<String> = Vec::new();
    let mut rest = svg;
    while let Some(i) = rest.find('<') {
        let end = rest[i..].find('>').ok_or("unclosed tag")? + i;
        let tag = &rest[i + 1..end];
        rest = &rest[end + 1..];
        if tag.starts_with('?') || tag.starts_with('!') {
            continue;
        }
        if let Some(name) = tag.strip_prefix('/') {
            let top = open.pop().ok_or(format!("</{name}> closes nothing"))?;
            if top != name.trim() {
                return Err(format!("</{name}> closes <{top}>"));
            }
        } else if !tag.ends_with('/') {
            open.push(tag.split_whitespace().next().unwrap_or("").to_string());
        }
    }
    if open.is_empty() {
        Ok(())
    } else {
        Err(format!("never closed: {open:?}"))
    }
}

/// Checks a chart snapshot: an SVG document with one line per quantity
/// and the quantities with their units on the axes.
fn assert_chart_svg(svg: &str, labels: &[&str]) {
    assert!(svg.starts_with("<svg"), "{svg}");
    well_formed(svg).unwrap_or_else(|e| panic!("{e}:\n{svg}"));
    let lines = svg
        .split("<polyline")
        .skip(1)
        .filter(|p| p.contains(&format!("stroke-width=\"{}\"", crate::plot::LINE_WIDTH)))
        .count();
    assert_eq!(lines, labels.len(), "one line per quantity:\n{svg}");
    for l in labels {
        assert!(svg.contains(&format!(">{l}<")) || svg.contains(&format!(">\n{l}\n<")), "no {l:?} in:\n{svg}");
    }
}

/// `p` through the snapshot writer: the file is named after the device and
/// the time, holds the chart, and a second snapshot in the same second
/// does not overwrite the first.
#[test]
fn snapshot_writes_the_chart_as_svg() {
    let mut rig = Rig::new();
    rig.moving_for(10);
    rig.select(Address::PowerCube { module: 17 });
    rig.keys("p");
    let req = rig.app.snapshot.take().unwrap();
    let dir = tempfile::tempdir().unwrap();
    let when = std::time::UNIX_EPOCH + Duration::from_secs(1_796_182_576);
    let path = super::snapshot::write(dir.path(), &req, when).unwrap();
    assert_eq!(path, dir.path().join("axisctl-chart-powercube-17-20261202T033616Z.svg"));
    let svg = std::fs::read_to_string(&path).unwrap();
    assert_chart_svg(&svg, &["position [m]", "velocity [m/s]", "current [A]"]);
    assert!(svg.contains("PowerCube 17 · last 30 s"), "{svg}");
    let again = super::snapshot::write(dir.path(), &req, when).unwrap();
    assert_eq!(again, dir.path().join("axisctl-chart-powercube-17-20261202T033616Z-2.svg"));
    assert_eq!(std::fs::read_to_string(&path).unwrap(), svg, "the first file stands");
    // A directory that cannot be written: an error, said in the events.
    let gone = dir.path().join("gone");
    let e = super::snapshot::write(&gone, &req, when).unwrap_err();
    assert!(e.to_string().starts_with(&format!("cannot write {}", gone.display())), "{e}");
}

/// The real loop: `c` then `p` on a running dashboard write the chart of
/// the selected module into the snapshot directory and say where.
#[test]
fn the_snapshot_key_writes_an_svg_from_the_running_dashboard() {
    let clock: Arc<dyn Clock> = Arc::new(crate::clock::SystemClock);
    let bench = Bench::contract(Arc::clone(&clock));
    let pc = PowerCube::over_can(Box::new(bench.bus.open())).with_clock(Arc::clone(&clock));
    let source = CubeSource::new(pc, Some(vec![crate::proto::powercube::ModuleId::new(3).unwrap()]));
    let plans = vec![super::LinkPlan { name: "can".into(), sources: vec![Box::new(source)], reopen: None }];
    let dir = tempfile::tempdir().unwrap();
    let mut terminal = Terminal::new(TestBackend::new(100, 30)).unwrap();
    let files = || std::fs::read_dir(dir.path()).unwrap().count();
    let r = std::thread::scope(|scope| {
        let (key_tx, key_rx) = std::sync::mpsc::channel::<std::sync::mpsc::Sender<Event>>();
        scope.spawn(move || {
            let Ok(tx) = key_rx.recv() else { return };
            let press = |c| {
                let _ = tx.send(Event::Key(KeyEvent::new(KeyCode::Char(c), KeyModifiers::NONE)));
            };
            // A few polls first, so that the chart has samples.
            std::thread::sleep(Duration::from_millis(600));
            press('c');
            press('p');
            for _ in 0..100 {
                if files() > 0 {
                    break;
                }
                std::thread::sleep(Duration::from_millis(50));
            }
            press('q');
        });
        super::run_with_keys(&mut terminal, plans, 20.0, dir.path(), Arc::clone(&clock), move |tx| {
            let _ = key_tx.send(tx);
            Ok(())
        })
    });
    r.unwrap();
    let written: Vec<_> = std::fs::read_dir(dir.path()).unwrap().map(|e| e.unwrap().path()).collect();
    assert_eq!(written.len(), 1, "{written:?}");
    let name = written[0].file_name().unwrap().to_string_lossy().to_string();
    assert!(name.starts_with("axisctl-chart-powercube-3-") && name.ends_with("Z.svg"), "{name}");
    let svg = std::fs::read_to_string(&written[0]).unwrap();
    assert_chart_svg(&svg, &["position [rad]", "velocity [rad/s]", "current [A]"]);
    let screen = terminal.backend().to_string();
    assert!(screen.contains("chart written to"), "{screen}");
}

/// The pictures of docs/img, drawn by the dashboard's own code on the
/// simulated bench: (file name, screen).
fn docs_pictures() -> Vec<(&'static str, String)> {
    let (w, h) = (120, 36);
    let mut rig = Rig::new();
    rig.moving_for(40);
    rig.select(Address::PowerCube { module: 17 });
    let mut out = vec![("dashboard.svg", super::screenshot::svg(rig.terminal(w, h).backend().buffer()))];
    rig.keys("c");
    out.push(("dashboard-chart.svg", super::screenshot::svg(rig.terminal(w, h).backend().buffer())));
    rig.keys("v");
    out.push(("dashboard-overview.svg", super::screenshot::svg(rig.terminal(w, h).backend().buffer())));
    out
}

/// docs/img/dashboard*.svg (shown in the README and the guide) are what
/// the code draws now: a change to the screen fails here until
/// `scripts/screenshots.sh` draws them again.
#[test]
fn the_docs_pictures_are_what_the_dashboard_draws() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/img");
    let write = std::env::var_os("AXISCTL_WRITE_DOCS_IMG").is_some();
    for (name, svg) in docs_pictures() {
        well_formed(&svg).unwrap_or_else(|e| panic!("{name}: {e}"));
        let path = dir.join(name);
        if write {
            std::fs::create_dir_all(&dir).unwrap();
            std::fs::write(&path, &svg).unwrap();
            continue;
        }
        let committed = std::fs::read_to_string(&path).unwrap_or_default();
        assert!(committed == svg, "docs/img/{name} is not what the dashboard draws now: run scripts/screenshots.sh");
    }
}

/// The picture of a screen: every character where its cell is, in the
/// cell's colours, and the box lines as strokes.
#[test]
fn a_screen_as_svg() {
    use ratatui::style::{Modifier, Style};
    let mut buf = ratatui::buffer::Buffer::empty(ratatui::layout::Rect::new(0, 0, 6, 2));
    buf.set_string(0, 0, "┌a<b┐", Style::new().fg(Color::Red));
    buf.set_string(1, 1, "ok", Style::new().add_modifier(Modifier::REVERSED | Modifier::BOLD));
    let svg = super::screenshot::svg(&buf);
    well_formed(&svg).unwrap();
    assert!(svg.contains("width=\"50\" height=\"34\""), "{svg}");
    assert!(
        svg.contains("fill=\"#cd3131\">  a&lt;b</text>") || svg.contains("fill=\"#cd3131\"> a&lt;b</text>"),
        "{svg}"
    );
    assert!(
        svg.contains("<path d=\"M4.2 8.5H8.4M33.6 8.5H37.8M4.2 8.5V17.0M37.8 8.5V17.0\" stroke=\"#cd3131\""),
        "{svg}"
    );
    // Reversed: light background, dark text, bold.
    assert!(svg.contains("<rect x=\"8.4\" y=\"17.0\" width=\"16.8\" height=\"17\" fill=\"#d4d4d4\"/>"), "{svg}");
    assert!(svg.contains("fill=\"#1e1e1e\" font-weight=\"bold\">ok</text>"), "{svg}");
}

/// Every device answer reaches the bus 1 ms after its request: a burst's
/// answers are still to come when the next burst could go out.
struct OneMsLate;
impl Fault for OneMsLate {
    fn device_frame(&mut self, frame: CanFrame, out: &mut Vec<crate::link::mem::Delivery>) {
        out.push(crate::link::mem::Delivery { after: Duration::from_millis(1), frame });
    }
}

// A round has the next module's reads on the bus before the current
// module's answers are read, so the link does not idle while they cross to
// the host; each module still gets its own values, and one round later the
// same holds (nothing sent ahead is left over).
#[test]
fn a_round_sends_the_next_modules_reads_before_the_current_answers_are_read() {
    use crate::session::TraceEvent;
    let clock = VirtualClock::new();
    let shared: Arc<dyn Clock> = Arc::new(clock.clone());
    let bench = Bench::contract(Arc::clone(&shared));
    bench.bus.set_fault(Some(Box::new(OneMsLate)));
    let trace = Arc::new(std::sync::Mutex::new(Vec::new()));
    let mut pc = PowerCube::over_can(Box::new(bench.bus.open())).with_clock(Arc::clone(&shared));
    let seen = Arc::clone(&trace);
    pc.set_tracer(Box::new(move |ev| {
        let line = match ev {
            TraceEvent::Sent(s) => format!("sent {}", s.rsplit(' ').next().unwrap_or_default()),
            TraceEvent::Received(s) if s.contains(" ack") => "ack".into(),
            _ => return,
        };
        seen.lock().unwrap().push(line);
    }));
    let sources: Vec<Box<dyn DeviceSource>> = vec![Box::new(CubeSource::new(pc, None))];
    let mut worker = LinkWorker::new(0, sources, Arc::clone(&shared), 10.0);
    let LinkEvent::Discovered { devices, .. } = worker.discover() else { panic!("discover reports") };
    assert!(devices.len() >= 2, "{devices:?}");
    let mut polled = Vec::new();
    for _ in 0..3 {
        trace.lock().unwrap().clear();
        polled.clear();
        worker.round(&mut Vec::new, &mut |ev| {
            if let LinkEvent::Polled { device, result, .. } = ev {
                polled.push((device, result));
            }
        });
    }
    assert_eq!(polled.iter().map(|p| p.0).collect::<Vec<_>>(), devices);
    assert!(polled.iter().all(|p| p.1.is_ok()), "{polled:?}");
    for (d, p) in devices.iter().zip(&polled) {
        let (Address::PowerCube { module: m }, Some(snap)) = (d, p.1.as_ref().ok().and_then(|s| s.get::<CubeSnap>()))
        else {
            panic!("{p:?}")
        };
        assert!(snap.limits.max_pos > snap.limits.min_pos, "module {m}: {snap:?}");
    }
    let lines = trace.lock().unwrap().clone();
    let first_ack = lines.iter().position(|l| l == "ack").expect("answers read");
    let Address::PowerCube { module: second } = devices[1] else { unreachable!() };
    assert!(
        lines[..first_ack].iter().any(|l| *l == format!("sent {second}")),
        "module {second}'s reads went out only after the first answers were read: {lines:?}"
    );
    let reads = lines.iter().filter(|l| l.starts_with("sent")).count();
    assert_eq!(reads, lines.len() - reads, "every read sent in the round is answered in it: {lines:?}");
}

// The same for the Cdios modules of a node: module 1's reads are on the bus
// before module 0's replies are read, and both polls get their readings.
#[test]
fn a_round_sends_the_next_cdios_modules_reads_before_the_current_replies_are_read() {
    use crate::session::TraceEvent;
    let clock = VirtualClock::new();
    let shared: Arc<dyn Clock> = Arc::new(clock.clone());
    let bench = Bench::contract(Arc::clone(&shared));
    bench.bus.set_fault(Some(Box::new(OneMsLate)));
    let trace = Arc::new(std::sync::Mutex::new(Vec::new()));
    let mut session = Cdios::new(Box::new(bench.bus.open())).with_clock(Arc::clone(&shared));
    let seen = Arc::clone(&trace);
    session.set_tracer(Box::new(move |ev| {
        let line = match ev {
            TraceEvent::Sent(s) => format!("sent {}", s.rsplit(' ').next().unwrap_or_default()),
            TraceEvent::Received(_) => "received".into(),
            TraceEvent::Note(_) => return,
        };
        seen.lock().unwrap().push(line);
    }));
    let source = CdiosSource::new(session, NodeId::new(1).unwrap(), None, RetryPolicy::default());
    let mut worker = LinkWorker::new(0, vec![Box::new(source)], Arc::clone(&shared), 10.0);
    let LinkEvent::Discovered { devices, .. } = worker.discover() else { panic!("discover reports") };
    assert_eq!(devices.len(), 2, "{devices:?}");
    let mut polled = Vec::new();
    for _ in 0..3 {
        trace.lock().unwrap().clear();
        polled.clear();
        worker.round(&mut Vec::new, &mut |ev| {
            if let LinkEvent::Polled { device, result, .. } = ev {
                polled.push((device, result));
            }
        });
    }
    assert_eq!(polled.iter().map(|p| p.0).collect::<Vec<_>>(), devices);
    assert!(polled.iter().all(|p| p.1.as_ref().is_ok_and(|s| s.get::<CdiosSnap>().is_some())), "{polled:?}");
    let lines = trace.lock().unwrap().clone();
    let first_reply = lines.iter().position(|l| l == "received").expect("replies read");
    assert!(
        lines[..first_reply].iter().any(|l| l == "sent 1"),
        "module 1's reads went out only after the first replies were read: {lines:?}"
    );
    let reads = lines.iter().filter(|l| l.starts_with("sent")).count();
    assert_eq!(reads, 8, "four reads a module, none sent again: {lines:?}");
}
