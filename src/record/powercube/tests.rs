//! A recorded PowerCube motion keeps the module watchdog alive between
//! samples, on the simulated bench and virtual time.

use std::sync::Arc;
use std::time::Duration;

use super::*;
use crate::clock::VirtualClock;
use crate::device::powercube::Move;
use crate::proto::powercube::flags::state;
use crate::record::{halt_motion, record, HaltMotion, HaltWhen, Pace, Until};
use crate::session::powercube::PowerCube;
use crate::sim::bench::Bench;
use crate::sim::shared::lock;

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

// Samples 200 ms apart, four watchdog periods: without the refresh in the
// pause between them the module would trip 50 ms into the first one. Once
// the recording is over and the motion released, it does trip.
#[test]
fn a_recorded_motion_keeps_the_watchdog_alive_between_samples() {
    if in_child("record::powercube::tests::a_recorded_motion_keeps_the_watchdog_alive_between_samples") {
        return;
    }
    let vclock = VirtualClock::new();
    let clock: Arc<dyn Clock> = Arc::new(vclock.clone());
    let bench = Bench::contract(Arc::clone(&clock));
    let mut cubes = Cubes::new(PowerCube::over_can(Box::new(bench.bus.open())).with_clock(Arc::clone(&clock)));
    let m = ModuleId::new(3).unwrap();
    cubes.watchdog_on(m).unwrap();
    let mut s = CubeSampler::new(cubes, &[m], &[crate::device::powercube::param(ids::CUBE_STATE)]).unwrap();
    let mut worst = 0u32;
    let ramp = Move::Ramp { pos: 1.0, vel: Some(0.5), acc: Some(3.0) };
    let period = Some(Duration::from_millis(200));
    record(&mut s, clock.as_ref(), Pace::from_period(period), Until::Count(10), &|| false, &mut |sample, s| {
        worst |= sample.values[0] as u32;
        if sample.seq == 0 {
            s.cubes().move_supervised(m, ramp, false, false, 1)?;
        }
        Ok(())
    })
    .unwrap();
    assert_eq!(worst & state::COMM_ERROR, 0, "tripped while recording: {worst:#x}");
    assert!(s.cubes().deadman_refreshing());
    halt_motion(&mut s, Address::PowerCube { module: 3 }, HaltWhen::IfMoving, 1);
    s.release().unwrap();
    assert!(!s.cubes().deadman_refreshing());
    vclock.advance(Duration::from_millis(60));
    let mut pc = lock(&bench.powercube);
    pc.advance(clock.now());
    assert_ne!(pc.module(3).unwrap().cube_state() & state::COMM_ERROR, 0, "refreshes went on after the motion");
}
