//! A simulated Cdios node: a Cdios controller (type 6152) on CAN with 6168
//! motor driver controller modules, as "Cdios 6168 Command / Reply / Event
//! messages V2.0" (specs/cdios-6168-commands.txt) and the transport of the
//! specs README describe them. Every byte layout, range, default, selector
//! and error bit comes from `proto::cdios::table`; replies are made by
//! `table::encode_reply`.
//!
//! # Driving it
//!
//! Sans-IO and clock-injected: [`CdiosNode::handle_can`] and
//! [`CdiosNode::poll`] take `now`; nothing reads a clock. The modules run a
//! fixed control cycle of 1/512 s ([`CYCLE_NS`]) counted from construction,
//! so the state at an instant does not depend on how often the node is
//! polled; cycles in which nothing can change (motors at rest, no timers)
//! are skipped. Time never runs backwards: an earlier `now` changes nothing.
//! Input changes made through [`CdiosNode::module_mut`] take effect in the
//! first cycle after the instant the node was last brought up to (call
//! `poll(now)` first to place them exactly).
//!
//! # Bus
//!
//! - NMT on id 0: `[0x01, node]` starts the node (node 0 = all nodes);
//!   `0x02` stops it, `0x80` / `0x82` make it pre-operational, `0x81` resets it.
//!   Commands (`0x200 + node`) are answered (on `0x180 + node`) only while
//!   started; before that, and while stopped, they are ignored, and so are
//!   events. The node takes commands at once after the start; the 100 ms of
//!   the README is the client's margin.
//! - A CANopen SYNC (id 0x080, any length) fires the latched commands (10h
//!   selector 1, 16h selectors 01h / 11h, 23h selectors 1 / 3 / 5 / 7, 24h
//!   and 25h selector 1) and latches the position (21h selector 1). A latched
//!   motion is checked again at the SYNC and dropped if no longer allowed.
//! - Every other id is ignored (PowerCube modules share the bus), and so are
//!   empty frames. Short frames read as zero-padded.
//!
//! # Decisions where the manual is silent
//!
//! - **Power-up.** A node is constructed powered up long ago: initialised
//!   (no general error 4) but not started. [`CdiosNode::power_up`] and NMT
//!   reset (`0x81`) begin the 500 ms of general error 4, restore the
//!   configuration stored in EEPROM, disable the motors, clear outputs, event
//!   masks and the next GOTO speed, and set "position not initialized".
//! - **Checks, in order:** EEPROM busy (general 8, for any command to the
//!   node), initialising (4), address above 15 (the controller: 01h is
//!   answered, anything else is general 3), no module at the id (1), a code
//!   the table does not have for modules (3). Then the command's own checks
//!   (general 0 with the manual's bits). A selector outside the table gives
//!   the command's "selector out of range" bit, or general 6 (not supported)
//!   where its error table has none (01h, 05h, 22h, 26h).
//! - **Errors of 16h** go out with code 56h, as the manual prints them
//!   (the README tells clients to accept 56h and 96h).
//! - **05h store configuration** stores the 20h servo configuration
//!   (trajects included). It takes 260..750 ms, drawn from a generator seeded
//!   by the node id (deterministic), then the reply comes (never
//!   suppressed). The manual prints no error table for 05h: this simulation
//!   answers 85h general 0 with status 1 bit 0 while the motor is enabled
//!   ("must be disabled") and bit 1 for a key other than 43h 44h 53h.
//! - **'Confirm'** (no command of our specs sets it) is a switch of the node,
//!   [`CdiosNode::set_confirm`], on by default; off, it suppresses the replies
//!   the table marks suppressible. Errors and read replies always go out.
//! - **Identify (01h to the controller).** Selectors 0..7 give type and
//!   version of modules 2s and 2s+1 ([`MODULE_TYPE_6168`], [`MODULE_VERSION`];
//!   0 / 0 where no module is); the layout of 8..24 is not in our specs:
//!   selector 8 + m gives module m's serial number (u32, bytes 4..7), 24 is zero.
//! - **Motor model.** Speeds are RPM from encoder pulses and Pulses Per
//!   Revolution; positions are encoder pulses. A motion starts at the minimum
//!   speed and ramps at (max - min) / slope RPM/s, linear or sin² (Slope
//!   Profile), proportionally shorter for partial changes. A goto brakes so
//!   that it reaches the minimum speed just before the target, creeps, and
//!   stops on the target exactly; the setpoint is the target from the start
//!   and the motor is then held there (status 4 bit 2). Speeds of gotos and
//!   trajects are clamped to min..max, 0 meaning max. Status 1 bit 3 / bit 4:
//!   steady at the minimum speed / at the speed the motion aims for (its
//!   "maximum speed"). The real speed trails the desired one by
//!   [`SPEED_LAG_S`] (the RPM error is a bit negative while accelerating) and
//!   is limited by Maximum Voltage with a motor of [`RPM_PER_VOLT`] (status 3
//!   bit 6 then); status 3 bit 5 above [`MAX_ENCODER_HZ`].
//! - **Hold.** A held motor pushed ([`Motor6168::push`]) beyond Positioning
//!   Error from the setpoint is brought back at the minimum speed.
//! - **Inputs.** The simulated levels are logical ("active"); Failsafe is
//!   stored only. End switches sit at ±[`END_SWITCH_PULSES`] from the
//!   power-on position and can be forced; an enabled, checked switch in the
//!   direction of motion stops and disables the motor (status 2 bit 3 / 4,
//!   cleared by START). START option 2 runs onto the switch whatever the
//!   checking, and zeroes the position there (status 4 bit 7 says it
//!   resets the position). Index pulses come at every multiple of Pulses Per
//!   Revolution; Z is active in [`ZERO_WINDOW`]. The emergency input, and
//!   (when checked) an active Error or inactive Ready input, stop and disable
//!   an enabled motor and latch status 2 bit 5 (with bit 7 for Error/Ready);
//!   STOP option 3 clears the latch once the inputs are quiet, START option 5
//!   enables again. Watchdog, "motor does not run" and "wrong direction" come
//!   only from [`Motor6168::inject`].
//! - **Events** (27h): a status event `[66h, module, 0, s1..s4, 0]` whenever
//!   a masked bit changes (after a command, or in a control cycle); position
//!   timer events `[61h, module, 0, position, 0]`; speed timer events
//!   `[66h, module, 2, speed, rpm error, 0]` (the reply layouts of 21h
//!   selector 0 and 26h selector 2 with bit 6 set). Reading the status
//!   clears status 3 bit 0; an event does not.
//! - **Analog output #1** reads the motor regulating voltage while the
//!   motor is enabled.

mod commands;
mod config;
mod motor;

#[cfg(test)]
mod tests;

use std::time::{Duration, Instant};

pub use config::{ServoStore, TrajectDef};
pub use motor::{
    Fault, Inputs, Motor6168, CYCLE_NS, CYCLE_S, END_SWITCH_PULSES, MAX_ENCODER_HZ, MODULE_TYPE_6168, MODULE_VERSION,
    RPM_PER_VOLT, SPEED_LAG_S, ZERO_WINDOW,
};

use crate::proto::cdios::table::{self, Confirm, Target};
use crate::proto::cdios::transport::{self, answer_frame, padded};
use crate::proto::cdios::{ErrorReply, ModuleId, NodeId};
use crate::proto::CanFrame;
use commands::{Outcome, GENERAL_NOT_SUPPORTED};

/// How long the controller initialises after power-up or reset (general error 4).
pub const INIT_TIME: Duration = Duration::from_millis(500);
/// EEPROM programming time of 05h, inclusive bounds.
pub const STORE_MS: (u64, u64) = (260, 750);
/// The CANopen SYNC id.
pub const SYNC_ID: u32 = 0x080;

/// General error codes this node sends.
pub mod general {
    pub const NO_MODULE: u8 = 1;
    pub const UNKNOWN_COMMAND: u8 = 3;
    pub const INITIALISING: u8 = 4;
    pub const NOT_SUPPORTED: u8 = super::GENERAL_NOT_SUPPORTED;
    pub const EEPROM_BUSY: u8 = 8;
}

/// NMT state of the node.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum NmtState {
    PreOperational,
    Operational,
    Stopped,
}

#[derive(Debug, Clone, Copy)]
struct Programming {
    until: Instant,
    module: u8,
}

/// A Cdios controller node (type 6152) with 6168 modules.
#[derive(Debug, Clone)]
pub struct CdiosNode {
    node: NodeId,
    nmt: NmtState,
    t0: Instant,
    cycles: u64,
    initialising_until: Option<Instant>,
    programming: Option<Programming>,
    rng: u64,
    confirm: bool,
    /// Sorted by id, ids unique.
    modules: Vec<Motor6168>,
}

impl CdiosNode {
    /// A node with 6168 modules at `modules` (ids above 15 and repeats are
    /// dropped), powered up long ago: initialised, waiting for NMT start.
    pub fn new(node: NodeId, modules: &[u8], now: Instant) -> Self {
        let mut ms: Vec<Motor6168> = Vec::new();
        for &id in modules {
            if ModuleId::new(id).is_some() && !ms.iter().any(|m| m.id() == id) {
                ms.push(Motor6168::new(id, 6_168_000 + u32::from(node.get()) * 100 + u32::from(id)));
            }
        }
        ms.sort_by_key(|m| m.id());
        Self {
            node,
            nmt: NmtState::PreOperational,
            t0: now,
            cycles: 0,
            initialising_until: None,
            programming: None,
            rng: 0x9E37_79B9_7F4A_7C15 ^ u64::from(node.get()),
            confirm: true,
            modules: ms,
        }
    }

    /// The contract bench: node 1 with modules 0 and 1.
    pub fn contract(now: Instant) -> Self {
        Self::new(NodeId::FACTORY, &[0, 1], now)
    }

    pub fn node(&self) -> NodeId {
        self.node
    }

    pub fn nmt_state(&self) -> NmtState {
        self.nmt
    }

    pub fn confirm(&self) -> bool {
        self.confirm
    }

    /// The controller's 'Confirm' setting: off suppresses confirmations.
    pub fn set_confirm(&mut self, on: bool) {
        self.confirm = on;
    }

    /// Whether the EEPROM is being programmed at `now`.
    pub fn eeprom_busy(&self, now: Instant) -> bool {
        self.programming.is_some_and(|p| now < p.until)
    }

    pub fn module(&self, id: u8) -> Option<&Motor6168> {
        self.modules.iter().find(|m| m.id() == id)
    }

    pub fn module_mut(&mut self, id: u8) -> Option<&mut Motor6168> {
        self.modules.iter_mut().find(|m| m.id() == id)
    }

    /// In id order.
    pub fn modules(&self) -> impl Iterator<Item = &Motor6168> {
        self.modules.iter()
    }

    /// Switches the controller off and on at `now`: see the module docs.
    pub fn power_up(&mut self, now: Instant) {
        let mut sink = Vec::new();
        self.advance(now, &mut sink);
        self.reset(now);
    }

    fn reset(&mut self, now: Instant) {
        for m in &mut self.modules {
            m.reset();
        }
        self.nmt = NmtState::PreOperational;
        self.programming = None;
        self.initialising_until = Some(now + INIT_TIME);
    }

    /// A CAN frame seen on the bus; answers (replies, events, errors) are
    /// appended to `out`.
    pub fn handle_can(&mut self, now: Instant, frame: &CanFrame, out: &mut Vec<CanFrame>) {
        self.advance(now, out);
        if frame.is_extended() {
            return;
        }
        match frame.id() {
            transport::NMT_ID => self.nmt(now, frame.data()),
            SYNC_ID if self.nmt == NmtState::Operational => {
                for i in 0..self.modules.len() {
                    self.modules[i].sync();
                    self.module_events(i, out);
                }
            }
            _ if transport::command_node(frame) == Some(self.node) => self.command(now, frame, out),
            _ => {}
        }
    }

    /// Events due by `now` (timers, end of goto, end switches, EEPROM done...).
    pub fn poll(&mut self, now: Instant, out: &mut Vec<CanFrame>) {
        self.advance(now, out);
    }

    fn nmt(&mut self, now: Instant, data: &[u8]) {
        let (Some(&cmd), Some(&node)) = (data.first(), data.get(1)) else { return };
        if node != 0 && node != self.node.get() {
            return;
        }
        match cmd {
            transport::NMT_START => self.nmt = NmtState::Operational,
            0x02 => self.nmt = NmtState::Stopped,
            0x80 | 0x82 => self.nmt = NmtState::PreOperational,
            0x81 => self.reset(now),
            _ => {}
        }
    }

    /// Runs the control cycles up to `now`.
    fn advance(&mut self, now: Instant, out: &mut Vec<CanFrame>) {
        let target =
            u64::try_from(now.saturating_duration_since(self.t0).as_nanos() / u128::from(CYCLE_NS)).unwrap_or(u64::MAX);
        let mut events = Vec::new();
        while self.cycles < target {
            if self.modules.iter().all(Motor6168::is_static) {
                self.cycles = target;
                break;
            }
            self.cycles += 1;
            for m in &mut self.modules {
                m.cycle(&mut events);
            }
            self.send_events(&mut events, out);
        }
        if let Some(p) = self.programming.filter(|p| now >= p.until) {
            self.programming = None;
            if let Some(data) = motor_reply("store_configuration", p.module) {
                self.send(&data, out);
            }
        }
        if self.initialising_until.is_some_and(|t| now >= t) {
            self.initialising_until = None;
        }
    }

    fn send_events(&self, events: &mut Vec<[u8; 8]>, out: &mut Vec<CanFrame>) {
        if self.nmt == NmtState::Operational {
            out.extend(events.iter().map(|e| answer_frame(self.node, e)));
        }
        events.clear();
    }

    fn module_events(&mut self, index: usize, out: &mut Vec<CanFrame>) {
        let mut events = Vec::new();
        self.modules[index].status_events(&mut events);
        self.send_events(&mut events, out);
    }

    fn send(&self, data: &[u8; 8], out: &mut Vec<CanFrame>) {
        if self.nmt == NmtState::Operational {
            out.push(answer_frame(self.node, data));
        }
    }

    fn error(&self, code: u8, module: u8, general: u8, status: [u8; 2], out: &mut Vec<CanFrame>) {
        let mut data = ErrorReply::new(code, module, general, status[0], status[1]).to_data();
        if code == table::ANALOG_OUTPUTS {
            data[0] = table::ANALOG_OUTPUTS_ERROR_AS_PRINTED;
        }
        self.send(&data, out);
    }

    fn command(&mut self, now: Instant, frame: &CanFrame, out: &mut Vec<CanFrame>) {
        if self.nmt != NmtState::Operational {
            return;
        }
        let Some(data) = padded(frame.data()) else { return };
        let (code, addr, sel) = (data[0], data[1], data[2]);
        if self.eeprom_busy(now) {
            return self.error(code, addr, general::EEPROM_BUSY, [0; 2], out);
        }
        if self.initialising_until.is_some_and(|t| now < t) {
            return self.error(code, addr, general::INITIALISING, [0; 2], out);
        }
        if ModuleId::new(addr).is_none() {
            return if code == table::IDENTIFY {
                self.identify(addr, sel, out)
            } else {
                self.error(code, addr, general::UNKNOWN_COMMAND, [0; 2], out)
            };
        }
        let Some(index) = self.modules.iter().position(|m| m.id() == addr) else {
            return self.error(code, addr, general::NO_MODULE, [0; 2], out);
        };
        if !table::COMMANDS.iter().any(|c| c.code == code && c.target == Target::Module) {
            return self.error(code, addr, general::UNKNOWN_COMMAND, [0; 2], out);
        }
        match self.modules[index].command(&data) {
            Outcome::Reply { data: reply, always } => {
                let table_always = table::command_for(code, sel).is_none_or(|d| d.confirm == Confirm::Always);
                if always || table_always || self.confirm {
                    self.send(&reply, out);
                }
            }
            Outcome::Error { general, status } => self.error(code, addr, general, status, out),
            Outcome::Store { defaults } => {
                let m = &mut self.modules[index];
                if defaults {
                    m.load_defaults();
                }
                m.commit_eeprom();
                let ms = STORE_MS.0 + self.next_random() % (STORE_MS.1 - STORE_MS.0 + 1);
                self.programming = Some(Programming { until: now + Duration::from_millis(ms), module: addr });
            }
        }
        self.module_events(index, out);
    }

    fn identify(&self, addr: u8, sel: u8, out: &mut Vec<CanFrame>) {
        let Some(def) = table::command_for(table::IDENTIFY, sel) else {
            return self.error(table::IDENTIFY, addr, general::NOT_SUPPORTED, [0; 2], out);
        };
        let kind = |id: u8| self.module(id).map_or((0, 0), |_| (MODULE_TYPE_6168, MODULE_VERSION));
        let values: Vec<(&str, i64)> = if sel <= 7 {
            let (a, b) = (kind(2 * sel), kind(2 * sel + 1));
            vec![
                ("first_type", a.0.into()),
                ("first_version", a.1.into()),
                ("second_type", b.0.into()),
                ("second_version", b.1.into()),
            ]
        } else {
            let serial = self.module(sel.wrapping_sub(8)).map_or(0, Motor6168::serial).to_le_bytes();
            let serial = if sel == 24 { [0; 4] } else { serial };
            vec![
                ("byte4", serial[0].into()),
                ("byte5", serial[1].into()),
                ("byte6", serial[2].into()),
                ("byte7", serial[3].into()),
                ("byte8", 0),
            ]
        };
        match table::encode_reply(def, addr, sel, &values) {
            Ok(data) => self.send(&data, out),
            Err(_) => self.error(table::IDENTIFY, addr, general::NOT_SUPPORTED, [0; 2], out),
        }
    }

    /// xorshift64*: deterministic per node.
    fn next_random(&mut self) -> u64 {
        let mut x = self.rng;
        x ^= x >> 12;
        x ^= x << 25;
        x ^= x >> 27;
        self.rng = x;
        x.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
}

fn motor_reply(key: &str, module: u8) -> Option<[u8; 8]> {
    table::encode_reply(table::command(key)?, module, 0, &[]).ok()
}

/// `trip=`: a 6168 that runs too long reports "motor does not run".
impl crate::sim::fault::Jams for CdiosNode {
    fn moving(&mut self, _now: Instant) -> Vec<(u8, bool)> {
        self.modules().map(|m| (m.id(), m.running())).collect()
    }

    fn jam(&mut self, _now: Instant, id: u8) {
        if let Some(m) = self.module_mut(id) {
            m.inject(Fault::DoesNotRun);
        }
    }
}

impl CdiosNode {
    /// Enables every motor through the node's own inputs, as a client
    /// would: its NMT start, then each motor the start with option 5
    /// (enable).
    pub fn enable_all(&mut self, now: Instant) {
        use crate::proto::cdios::{Address, Command, Direction, StartOption};
        let id = self.node();
        self.handle_can(now, &transport::nmt_start(id), &mut Vec::new());
        let enable =
            Command::Start { sync: false, direction: Direction::Forward, option: StartOption::Enable, motor_speed: 0 };
        let modules: Vec<u8> = self.modules().map(|m| m.id()).collect();
        for m in modules.into_iter().filter_map(ModuleId::new) {
            if let Ok(data) = enable.encode(Address::Module(m)) {
                self.handle_can(now, &transport::command_frame(id, &data), &mut Vec::new());
            }
        }
    }
}
