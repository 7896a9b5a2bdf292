//! A simulated PA-CONTROL positioning controller behind its RS232 online
//! command port (specs/pa-control-interfaces.txt chapters 3, 5 and 6, with
//! the corrections of specs/README.md).
//!
//! API skeleton: behaviour follows in the next commits.

use std::time::Instant;

use crate::proto::pac::CheckRule;

/// One PA-CONTROL with its axes, inputs, outputs, flags and registers.
#[derive(Debug, Clone)]
pub struct PacController {
    axes: u8,
    check_rule: CheckRule,
    origin: Instant,
}

impl PacController {
    /// A controller with `axes` axes (at most 16), powered up at `now` in
    /// home position (status 1).
    pub fn new(axes: u8, now: Instant) -> Self {
        Self { axes: axes.min(crate::proto::pac::table::MAX_AXES), check_rule: CheckRule::Strict, origin: now }
    }

    /// RS232 bytes from the host, split anywhere; acknowledges are appended to `out`.
    pub fn handle_bytes(&mut self, _now: Instant, _bytes: &[u8], _out: &mut Vec<u8>) {
        unimplemented!("skeleton")
    }

    /// Runs the controller up to `now` (moves, reference drives, the automatic program).
    pub fn advance(&mut self, _now: Instant) {
        unimplemented!("skeleton")
    }

    /// The operating status of manual 6.4 (1 home, 11 automatic, 31 online, ...).
    pub fn status(&self) -> u16 {
        unimplemented!("skeleton")
    }

    /// The PA-CONTROL error number (Exxx); 0 = none.
    pub fn error(&self) -> u16 {
        unimplemented!("skeleton")
    }

    /// Configured axes (system parameter 2).
    pub fn axes(&self) -> u8 {
        self.axes
    }

    /// The position counter of an axis, in axis units (AE).
    pub fn axis_position(&self, _axis: u8) -> Option<f64> {
        unimplemented!("skeleton")
    }

    /// The current traverse speed of an axis (AE/s, magnitude).
    pub fn axis_speed(&self, _axis: u8) -> Option<f64> {
        unimplemented!("skeleton")
    }

    /// The 1910 axis status (0 in position, 1 moving, 2 stopped, 4 fault, 8 measuring mode).
    pub fn axis_status(&self, _axis: u8) -> Option<u8> {
        unimplemented!("skeleton")
    }

    /// The 1921 extended axis status word.
    pub fn axis_ext_status(&self, _axis: u8) -> Option<u32> {
        unimplemented!("skeleton")
    }

    /// Whether the axis has been referenced (reference drive or 0A96).
    pub fn axis_referenced(&self, _axis: u8) -> Option<bool> {
        unimplemented!("skeleton")
    }

    /// Whether the axis is switched on (0A97 / 0A98).
    pub fn axis_on(&self, _axis: u8) -> Option<bool> {
        unimplemented!("skeleton")
    }

    /// An axis parameter (0800 list) of an axis.
    pub fn axis_param(&self, _axis: u8, _param: u8) -> Option<f64> {
        unimplemented!("skeleton")
    }

    /// Whether limit switch monitoring is on for an axis (0AA2).
    pub fn limit_monitoring(&self, _axis: u8) -> Option<bool> {
        unimplemented!("skeleton")
    }

    /// The bench side changes an input (1..=1024).
    pub fn set_input(&mut self, _n: u16, _on: bool) {
        unimplemented!("skeleton")
    }

    pub fn input(&self, _n: u16) -> Option<bool> {
        unimplemented!("skeleton")
    }

    pub fn output(&self, _n: u16) -> Option<bool> {
        unimplemented!("skeleton")
    }

    pub fn flag(&self, _n: u16) -> Option<bool> {
        unimplemented!("skeleton")
    }

    /// Integer register N (1..=1024).
    pub fn int_register(&self, _n: u16) -> Option<i32> {
        unimplemented!("skeleton")
    }

    /// Real number register R (1..=1024).
    pub fn float_register(&self, _n: u16) -> Option<f64> {
        unimplemented!("skeleton")
    }

    /// A system parameter (0700 list).
    pub fn system_param(&self, _n: u16) -> Option<i64> {
        unimplemented!("skeleton")
    }

    /// The bench side: an axis' power pack ready or not.
    pub fn set_power_ready(&mut self, _axis: u8, _ready: bool) {
        unimplemented!("skeleton")
    }

    /// The bench side: force a limit switch activated (`Some(true)`), not
    /// activated (`Some(false)`, e.g. bridged), or back to following the
    /// axis position (`None`).
    pub fn force_limit_switch(&mut self, _axis: u8, _positive: bool, _state: Option<bool>) {
        unimplemented!("skeleton")
    }

    /// Which CHECK rule the acknowledges use (default [`CheckRule::Strict`]).
    pub fn set_check_rule(&mut self, rule: CheckRule) {
        self.check_rule = rule;
    }

    /// Whether a start-and-wait command (0A87 / 0A89 / 0A84 / 0A93) is unfinished.
    pub fn busy(&self) -> bool {
        unimplemented!("skeleton")
    }

    /// The instant the controller was powered up.
    pub fn powered_up(&self) -> Instant {
        self.origin
    }
}

impl crate::link::mem::ByteDevice for PacController {
    fn on_bytes(&mut self, now: Instant, bytes: &[u8], out: &mut Vec<u8>) {
        self.handle_bytes(now, bytes, out);
    }
    fn poll(&mut self, now: Instant, _out: &mut Vec<u8>) {
        self.advance(now);
    }
}
