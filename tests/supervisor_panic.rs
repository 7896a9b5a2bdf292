//! The motion supervisor's panic hook, in a process of its own (the hook and
//! the stop record are process-wide): a panic on another thread than the
//! one that waits ends the wait at once, whatever the poll interval, and the
//! wait halts the module. And the build keeps unwinding panics, without
//! which the unwind guard never runs.

use std::sync::Arc;
use std::time::{Duration, Instant};

use axisctl::clock::{Clock, SystemClock};
use axisctl::device::powercube::{Cubes, Goal, Move, WaitSpec};
use axisctl::device::supervisor::{self, StopReason};
use axisctl::proto::powercube::flags::state;
use axisctl::proto::powercube::ModuleId;
use axisctl::session::powercube::PowerCube;
use axisctl::sim::bench::Bench;
use axisctl::sim::shared::lock;

#[test]
fn a_panic_on_another_thread_halts_a_supervised_wait() {
    supervisor::install_panic_hook();
    supervisor::arm().unwrap();
    let clock: Arc<dyn Clock> = Arc::new(SystemClock);
    let bench = Bench::contract(Arc::clone(&clock));
    let mut cubes = Cubes::new(PowerCube::over_can(Box::new(bench.bus.open())).with_clock(Arc::clone(&clock)));
    let m = ModuleId::new(3).unwrap();
    cubes.move_supervised(m, Move::Ramp { pos: 2.0, vel: Some(0.2), acc: None }, false, true, 3).unwrap();
    assert!(!supervisor::stop_requested());
    let bug = std::thread::Builder::new()
        .name("bug".into())
        .spawn(|| {
            std::thread::sleep(Duration::from_millis(300));
            panic!("injected for the test");
        })
        .unwrap();
    // A poll interval far longer than the test: only the panic can end it.
    let spec = WaitSpec { poll: Duration::from_secs(60), timeout: Duration::from_secs(120), halt_attempts: 3 };
    let t0 = Instant::now();
    let e = cubes
        .wait(m, Goal::RampEnd { target: 2.0, ticks: false }, spec, &supervisor::stop_requested, &mut |_, _| {})
        .unwrap_err();
    assert!(t0.elapsed() < Duration::from_secs(5), "the panic woke the wait: {:?}", t0.elapsed());
    assert_eq!(e.to_string(), "interrupted: module 3 halted");
    assert!(bug.join().is_err(), "the thread did panic");
    let reason = supervisor::stop_reason();
    assert!(
        matches!(&reason, Some(StopReason::Panic(p)) if p.contains("'bug'") && p.contains("injected for the test")),
        "{reason:?}"
    );
    assert!(reason.unwrap().to_string().starts_with("a thread panicked (thread 'bug' at "));
    let mut pc = lock(&bench.powercube);
    pc.advance(clock.now());
    let module = pc.module(3).unwrap();
    assert_ne!(module.cube_state() & state::HALTED, 0, "module 3 halted");
    assert_eq!(module.velocity(), 0.0, "module 3 stands");
}

/// `panic = "abort"` in a profile would end the process at the panic,
/// before any unwind guard could halt a device.
#[test]
fn no_profile_aborts_on_panic() {
    let manifest = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/Cargo.toml")).unwrap();
    let squeezed: String = manifest.chars().filter(|c| !c.is_whitespace()).collect();
    assert!(!squeezed.contains("panic=\"abort\""), "Cargo.toml sets panic = \"abort\"");
}
