//! The dead-man backstop on the simulated contract bench, on virtual time:
//! the module watchdog (manual 13) trips 50 ms after the last refresh, so a
//! wait that left a longer gap would end in COMM_ERROR.

use std::sync::{Arc, Mutex};
use std::time::Duration;

use super::*;
use crate::clock::{Clock, VirtualClock};
use crate::device::powercube::{Goal, Move, WaitSpec};
use crate::device::tests::{recorded_bench, Recorded};
use crate::proto::powercube::can::{classify, Broadcast, CanMessage};
use crate::proto::powercube::flags::state;
use crate::proto::CanFrame;
use crate::session::powercube::PowerCube;
use crate::sim::bench::Bench;
use crate::sim::shared::lock;

struct Rig {
    clock: VirtualClock,
    bench: Bench,
    cubes: Cubes,
    sent: Arc<Mutex<Vec<CanFrame>>>,
}

fn rig() -> Rig {
    let Recorded { clock, shared, bench, link, sent } = recorded_bench();
    let mut pc = PowerCube::over_can(Box::new(link)).with_clock(shared);
    // Answers may come late on purpose below; none is lost.
    pc.set_timeout(Duration::from_millis(400));
    Rig { clock, bench, cubes: Cubes::new(pc), sent }
}

/// Runs the test named `name` again in a child process of this test binary
/// and returns true here, unless this is that child: a supervised motion
/// asks the process-wide motion supervisor, which another test of this
/// binary may have told to stop (a recorded panic stays recorded).
fn in_child(name: &str) -> bool {
    const CHILD: &str = "AXISCTL_DEADMAN_TEST_CHILD";
    if std::env::var_os(CHILD).is_some() {
        return false;
    }
    let out = std::process::Command::new(std::env::current_exe().unwrap())
        .args(["--exact", name, "--nocapture", "--test-threads=1"])
        .env(CHILD, "1")
        .output()
        .unwrap();
    let text = format!("{}{}", String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
    assert!(out.status.success() && text.contains("1 passed"), "{text}");
    true
}

fn id(m: u8) -> ModuleId {
    ModuleId::new(m).unwrap()
}

impl Rig {
    fn state(&self, m: u8) -> u32 {
        let mut pc = lock(&self.bench.powercube);
        pc.advance(self.clock.now());
        pc.module(m).unwrap().cube_state()
    }

    fn online(&self, m: u8) -> bool {
        lock(&self.bench.powercube).module(m).unwrap().watchdog_online()
    }

    fn config(&mut self, m: u8) -> u32 {
        self.cubes.get_u32(id(m), ids::CONFIG).unwrap()
    }

    /// A 2 s ramp of module 3 with its wait, as `move-ramp --wait` runs it;
    /// every poll also checks that the module never tripped.
    fn waited_ramp(&mut self) -> Result<(), Error> {
        let ramp = Move::Ramp { pos: 1.0, vel: Some(0.5), acc: Some(3.0) };
        self.cubes.move_supervised(id(3), ramp, false, false, 1)?;
        let spec = WaitSpec { poll: Duration::from_millis(20), timeout: Duration::from_secs(10), halt_attempts: 1 };
        let mut worst = 0;
        let end = self
            .cubes
            .wait(id(3), Goal::RampEnd { target: 1.0, ticks: false }, spec, &|| false, &mut |_, c| worst |= c);
        assert_eq!(worst & state::COMM_ERROR, 0, "the watchdog tripped during the wait");
        end.map(|_| ())
    }

    /// Refresh broadcasts sent since the last call.
    fn refreshes(&self) -> usize {
        let sent: Vec<CanFrame> = lock(&self.sent).drain(..).collect();
        sent.iter()
            .filter(|f| matches!(classify(f), Ok(Some(CanMessage::Broadcast(Broadcast::WatchdogRefresh)))))
            .count()
    }
}

#[test]
fn a_wait_keeps_an_online_watchdog_alive_and_its_end_lets_it_trip() {
    if in_child("device::powercube::deadman::tests::a_wait_keeps_an_online_watchdog_alive_and_its_end_lets_it_trip") {
        return;
    }
    let mut r = rig();
    r.cubes.watchdog_on(id(3)).unwrap();
    r.waited_ramp().unwrap();
    assert!(r.refreshes() >= 2000 / 20, "about one refresh per 20 ms of the 2 s ramp");
    let end = r.clock.now();
    r.cubes.release_deadman().unwrap();
    assert!(!r.cubes.deadman_refreshing());
    // Nothing refreshes now: the watchdog, still on, halts the module.
    r.clock.advance(Duration::from_millis(60));
    assert_ne!(r.state(3) & state::COMM_ERROR, 0, "refreshes went on after the motion: {:#x}", r.state(3));
    assert!(r.clock.now() - end < Duration::from_millis(100));
    assert_ne!(r.config(3) & config::WATCHDOG_ENABLE, 0, "Auto leaves the watchdog as it found it: on");
}

#[test]
fn without_a_watchdog_nothing_is_refreshed_or_switched() {
    if in_child("device::powercube::deadman::tests::without_a_watchdog_nothing_is_refreshed_or_switched") {
        return;
    }
    let mut r = rig();
    r.waited_ramp().unwrap();
    r.cubes.release_deadman().unwrap();
    assert_eq!(r.refreshes(), 0);
    assert_eq!(r.config(3) & config::WATCHDOG_ENABLE, 0);
}

#[test]
fn arm_switches_the_watchdog_on_for_the_motion_and_off_after_it() {
    if in_child("device::powercube::deadman::tests::arm_switches_the_watchdog_on_for_the_motion_and_off_after_it") {
        return;
    }
    let mut r = rig();
    r.cubes.set_deadman(Deadman::Arm).unwrap();
    let ramp = Move::Ramp { pos: 1.0, vel: Some(0.5), acc: Some(3.0) };
    r.cubes.move_supervised(id(3), ramp, false, false, 1).unwrap();
    assert!(r.online(3), "online before the wait starts");
    assert_ne!(r.config(3) & config::WATCHDOG_ENABLE, 0);
    let spec = WaitSpec { poll: Duration::from_millis(20), timeout: Duration::from_secs(10), halt_attempts: 1 };
    r.cubes
        .wait(id(3), Goal::RampEnd { target: 1.0, ticks: false }, spec, &|| false, &mut |_, c| {
            assert_eq!(c & state::COMM_ERROR, 0)
        })
        .unwrap();
    r.cubes.release_deadman().unwrap();
    assert_eq!(r.config(3) & config::WATCHDOG_ENABLE, 0, "restored: off");
    assert!(!r.online(3));
    r.clock.advance(Duration::from_secs(1));
    assert_eq!(r.state(3) & state::ERROR, 0, "off again: no trip after the motion");
}

#[test]
fn a_process_that_stops_refreshing_mid_motion_leaves_the_module_halted_within_50_ms() {
    if in_child("device::powercube::deadman::tests::a_process_that_stops_refreshing_mid_motion_leaves_the_module_halted_within_50_ms") {
        return;
    }
    let mut r = rig();
    r.cubes.set_deadman(Deadman::Arm).unwrap();
    let ramp = Move::Ramp { pos: 2.0, vel: Some(0.5), acc: Some(3.0) };
    r.cubes.move_supervised(id(3), ramp, false, false, 1).unwrap();
    r.cubes.session().pause(Duration::from_millis(500)).unwrap();
    assert_eq!(r.state(3) & state::COMM_ERROR, 0, "refreshed while the process lives");
    // The process dies here: its Cubes is gone, nothing more is sent.
    let Rig { clock, bench, cubes, .. } = r;
    drop(cubes);
    let died = clock.now();
    clock.advance(Duration::from_millis(50));
    let mut pc = lock(&bench.powercube);
    pc.advance(clock.now());
    let m = pc.module(3).unwrap();
    assert_ne!(m.cube_state() & (state::COMM_ERROR | state::HALTED), 0, "{:#x}", m.cube_state());
    let stopped_at = m.position();
    drop(pc);
    clock.advance(Duration::from_secs(1));
    let mut pc = lock(&bench.powercube);
    pc.advance(clock.now());
    assert_eq!(pc.module(3).unwrap().position(), stopped_at, "stands still");
    assert!(clock.now() > died);
}

#[test]
fn a_slow_answer_does_not_hold_the_refresh_back() {
    if in_child("device::powercube::deadman::tests::a_slow_answer_does_not_hold_the_refresh_back") {
        return;
    }
    let mut r = rig();
    // Every answer 120 ms late: more than two watchdog periods per poll.
    r.bench.inject_faults("delay=120ms".parse().unwrap(), 1);
    r.cubes.set_deadman(Deadman::Arm).unwrap();
    r.waited_ramp().unwrap();
    let st = r.cubes.session().stop_refresh().unwrap();
    assert!(st.max_gap <= Duration::from_millis(21), "longest gap {:?}", st.max_gap);
}

#[test]
fn arm_is_refused_on_rs232_before_anything_is_sent() {
    let clock: Arc<dyn Clock> = Arc::new(VirtualClock::new());
    let bench = Bench::contract(Arc::clone(&clock));
    let link = bench.powercube_rs232_link(Arc::clone(&clock), None);
    let mut cubes = Cubes::new(PowerCube::over_rs232(Box::new(link), 9600).with_clock(clock));
    let e = cubes.set_deadman(Deadman::Arm).unwrap_err();
    assert!(e.nothing_sent(), "{e}");
    assert!(e.to_string().starts_with("--deadman: the watchdog is a CAN feature"), "{e}");
}
