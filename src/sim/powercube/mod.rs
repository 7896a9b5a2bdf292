//! A simulated PowerCube bench: drive modules behind CAN or RS232, as
//! "Data exchange with PowerCube" (specs/powercube-data-exchange.txt, with
//! the corrections of specs/README.md) describes them.
//!
//! # Driving it
//!
//! Sans-IO and clock-injected: every entry point takes `now`; nothing reads
//! a clock or sleeps. Motion is a closed-form function of time (see
//! `traj.rs`), and timed events (end of a profile, reaching a soft limit,
//! watchdog expiry) are applied at the exact instant they fall on, lazily,
//! whenever the module is next touched. So `advance(now)` once after 10 s
//! gives the same state as a thousand calls 10 ms apart, and tests run on
//! virtual time. Time never runs backwards: an earlier `now` changes nothing.
//!
//! [`PowerCubeBus::handle_can`] takes host frames and appends acknowledges
//! (on `0x0A0 + M`); it ignores ids that are not PowerCube's (a Cdios node
//! shares the bus), acknowledges of other modules, frames that do not decode
//! and broadcasts' answers (there are none). [`PowerCubeBus::handle_rs232`]
//! takes a byte stream split anywhere; address 0 is a broadcast there.
//!
//! # The modules
//!
//! Rotary modules work in rad, linear ones in m (CONFIGID_MOD_LINEAR set in
//! DefConfig and Config). Every parameter of the manual's table answers; the
//! values are in `defaults.rs`: rotary MinPos/MaxPos -3.1/3.1 rad, MaxVel
//! 1.5 rad/s, MaxAcc 3 rad/s², linear 0..1 m (the manual's ramp to 0.75 must
//! fit), 0.1 m/s, 0.5 m/s², MaxCur 5 A, 24 V logic, 48 V motor, 35 °C,
//! firmware 4.6.01 (0x4601), IncRatio = DefPulsesPerTurn * DefGearRatio per output
//! turn (2π rad, or DefLinRatio m).
//!
//! Decisions where the manual is silent (the vendor's library, libm5api,
//! decides where it has an opinion: what it sends and expects is what real
//! modules do):
//!
//! - **Firmware.** Module 17 keeps firmware 3.5.18 (the contract's `scan`
//!   shows 13592) and, like real modules before 4.6.01, does not answer
//!   ActFTemp, ActFMotorSupply and ActFLogicSupply; every other module runs
//!   4.6.01 and answers them.
//! - **Commands outside the manual.** The library's padded GetExtended (the
//!   two bytes and zeros up to 8) is answered like the short one. Its
//!   SaveParameters (0x10) is not a command of the manual: the module does
//!   not answer it ([`PowerCubeBus::set_tracer`] hears why, `monitor` shows
//!   it as an unknown command id).
//! - **Current in digits** (ICUR_MODE, ICUR_ACK) is taken in the manual's
//!   Int16 and in the library's Int32.
//!
//! - **Parameters.** GetExtended of a parameter the table marks write-only
//!   (TargetPos/Vel/Acc) or not readable (DefA0) answers the current value;
//!   an id outside the table gets no answer. SetExtended of a read-only
//!   parameter gets no answer either (as an unknown one: an acknowledge
//!   would tell the client a write took that did not); with data that does
//!   not decode as the parameter's type, or a non-finite float, it is
//!   acknowledged and changes nothing. Writes are
//!   limited (manual 12): MinPos/MaxPos to DefMinPos..DefMaxPos (and MinPos
//!   <= MaxPos), MaxVel/MaxAcc/MaxCur/MaxDeltaPos to their Def values,
//!   TargetVel/TargetAcc to MaxVel/MaxAcc (magnitude), target positions to
//!   MinPos..MaxPos once homed. The *Inc parameters are signed ticks. The
//!   hardware bits LINEAR / LINEAR_SCREW of Config cannot be changed. A new
//!   HomeOffset takes effect at the next homing. ActMin/Max supply and
//!   temperature limits are stored; the simulated supplies never leave them.
//!   The servo follows exactly: DeltaPos is 0, IPolPos = ActPos, ActPos_ is
//!   the position one 1 ms servo cycle earlier.
//! - **Power on.** Not homed, CubeState 0, ActPos = DefHomeOffset (manual 12),
//!   TargetVel / TargetAcc at half of MaxVel / MaxAcc.
//!   Motion commands are accepted before homing ("run the module only at slow
//!   speed") unless CONFIGID_MOD_M3_COMPATIBLE is set; soft limits apply only
//!   once homed, when the coordinate system is fixed.
//! - **Homing.** The home switch edge lies `home_distance` (0.3 rad, 0.03 m)
//!   from the power-on position in the direction of DefHomeVel. Home clears
//!   HOME_OK, sets MOTION and ramps there at |DefHomeVel| / DefHomeAcc, then
//!   creeps onto the edge for 0.2 s (about 1.7 s in all from power on). At the
//!   edge ActPos becomes HomeOffset (PosCount keeps counting, RefPosCount
//!   latches it) and HOME_OK and RAMP_END are set (the vendor's library
//!   waits for both at the end of homing).
//!   With ZERO_MOVE_AFTER_HOK a ramp to 0 follows. The switch (STATE_SWR,
//!   DioSetup INSWR) is active just past the edge. Home is ignored while
//!   homing, halted or in error.
//! - **Ramps** (FRAMP/IRAMP, *_ACK): trapezoidal, triangular when short, with
//!   TargetVel/TargetAcc limited to DefMinVel..MaxVel and DefMinAcc..MaxAcc.
//!   A new command while moving re-plans from the current position and
//!   velocity (braking first if needed). RAMP_ACC / RAMP_STEADY / RAMP_DEC
//!   follow the profile; at the end RAMP_END is set and MOTION cleared.
//!   FRAMPLOOP ramps to the target and back forever; FCOSLOOP moves
//!   `from + (to - from)(1 - cos(πt/T))/2` with T the given time, lengthened
//!   so the peak speed stays within MaxVel.
//! - **Steps** (FSTEP/ISTEP/SetIStep): constant speed to the target in the
//!   given time, longer if that would exceed MaxVel; INPROGRESS while running.
//!   A step arriving during one is buffered (FULLBUFFER) and starts when the
//!   running one ends; a further one replaces the buffered one.
//! - **Velocity** (FVEL/IVEL): ramps at MaxAcc to the velocity (limited to
//!   MaxVel) and keeps it; MOTION stays set until a velocity of 0 is reached.
//! - **Current** (FCUR/ICUR, 0.01 A per digit): the commanded current, limited
//!   to the nominal current MaxCur/2 unless ALLOW_FULL_CUR (then MaxCur), sets
//!   STATE_CURLIMIT when limited. The unloaded motor runs up at MaxAcc to
//!   MaxVel * I / DefMaxCur. Cur and RawCur read the commanded current in
//!   this mode, otherwise a current model from acceleration and speed.
//! - **Soft limits.** Leaving MinPos..MaxPos while homed (velocity, current,
//!   re-planned ramps) stops the module at that instant with
//!   BEYOND_SOFT | ERROR | HALTED. Moving back in from beyond is allowed.
//! - **Halt / errors.** Halt stops at once (HALTED); the step buffer and any
//!   SYNC_MOTION command are dropped. A halted or failed module acknowledges
//!   motion commands but does not move. Reset clears HALTED, ERROR and the
//!   resettable errors (TOW, COMM when the watchdog is offline or fresh,
//!   BEYOND_SOFT, POW_VOLT_ERR with its POWERFAULT, CURLIMIT, bit 27 as
//!   LOGIC_VOLT except on firmware 3.5.14..3.5.1D where it is POW_SETUP_ERR);
//!   other power faults, CPU_OVERLOAD and BEYOND_HARD survive it, and so do
//!   HALTED and ERROR with them. HOME_OK survives a Reset.
//! - **Watchdog** (manual 13). With WATCHDOG_ENABLE in Config, `[0x07]` to a
//!   module toggles it online/offline (going online counts as a refresh).
//!   Online, a module not refreshed by the broadcast `[0x07, 0]` within 50 ms
//!   stops at exactly last refresh + 50 ms with COMM_ERROR | ERROR | HALTED.
//!   Recovery: switch it offline and Reset, or refresh again and Reset.
//!   Clearing WATCHDOG_ENABLE takes it offline. A refresh does not bring an
//!   offline watchdog online (the Config table's "activated automatically
//!   by the first life sign" is not modelled: section 13 switches it with
//!   0x07), and the trip is the instant of last refresh + 50 ms as the
//!   simulator receives it: frames a loaded host delivers late to it count
//!   from when they arrive.
//! - **Brake.** With BRAKE_PRESENT, BRAKEACTIVE is set from a halt (or an
//!   error stop, or power on with BRAKE_AT_POWERON) until the next motion.
//!   DefBrakeTimeOut is reported, not waited for.
//! - **CAN only** (manual 7.2): DISABLE_ACK suppresses every acknowledge but
//!   GetExtended's; SYNC_MOTION keeps the last motion command (its acknowledge
//!   is sent at once) until the broadcast StartMotion `[0x0f, 0]`.
//! - **Extended acknowledges** (motion ids 14..23): the position when the
//!   command arrived (float, or int32 ticks for the I* ids), the short state
//!   after the command was taken, and DIO = inputs | outputs << 4.
//! - **DIO.** DioSetup reads inputs (bits 0..3), outputs (4..7, writable) and
//!   the home switch (8); the limit switches (9, 10) are never active.
//!   [`Module::set_inputs`] drives the inputs.
//! - **RS232.** A frame whose TELID length disagrees with the bytes framed is
//!   ignored (manual 4.3). The manual says modules do not check the BCC; the
//!   simulation does (the shared decoder drops such frames), so a tool with
//!   a wrong BCC gets no answer here. Frames from modules are ignored.
//! - **Setup** has SETUPID_MOD_4IN_4OUT and the interface the last command
//!   came on (SETUPID_MOD_CAN at power on, SETUPID_MOD_RS232 after RS232).
//! - **Not modelled:** Config's switch options (SWR_*, SW1_*, SW2_*,
//!   CHANGE_SWR_TO_LIMIT), DISABLE_ON_HALT and BRAKE timing are stored and
//!   read back but change nothing; there is no following error (TOW_ERROR
//!   only by [`Module::inject_error`]), no hard limit switches, no heating.
//! - **Broadcasts.** Reset, Home, Halt, watchdog refresh, SavePos (stores
//!   ActFSavedPos) and StartMotion act on every module; ChangeBaudrate is
//!   ignored. On RS232 both `[cmd, 0]` (the library's, axisctl's) and the
//!   command byte alone are taken. ResetTime zeroes the 16-bit millisecond stamp of ActFPosTime.

mod defaults;
mod module;
mod params;
pub(super) mod traj;

#[cfg(test)]
mod tests;

use std::time::Instant;

pub use defaults::{Defaults, DEFAULT_VERSION, LEGACY_MODULE, LEGACY_VERSION};
pub use module::{Module, SERVO_CYCLE_S, WATCHDOG_PERIOD_S};
pub use params::{LOGIC_SUPPLY_V, MOTOR_SUPPLY_V, TEMPERATURE_C};

use module::Iface;

use crate::proto::can::CanFrame;
use crate::proto::powercube::can::{ack_frame, classify, Broadcast, CanMessage, GET_BASE, PUT_BASE};
use crate::proto::powercube::rs232::{self, Direction};
use crate::proto::powercube::table;
use crate::proto::powercube::ModuleId;
use crate::proto::powercube::Request;

/// Rotary (rad) or linear (m).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum ModuleKind {
    Rotary,
    Linear,
}

/// What makes one simulated module different from another.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct ModuleSpec {
    pub id: ModuleId,
    pub kind: ModuleKind,
    pub serial: u32,
    pub version: u16,
}

impl ModuleSpec {
    /// A module with the bench's version (module 17 the legacy one) and a
    /// serial derived from its id.
    pub fn new(id: ModuleId, kind: ModuleKind) -> Self {
        let version = if id.get() == LEGACY_MODULE { LEGACY_VERSION } else { DEFAULT_VERSION };
        Self { id, kind, serial: 12328 + u32::from(id.get()), version }
    }
}

/// Where a bus reports, in words, each host frame to one of its modules
/// that it leaves unanswered (`axisctl --trace sim`): a caller waiting out
/// its timeout can see why.
pub type Tracer = fn(&str);

/// A standard id a host sends PowerCube commands on (`0x0C0 + M`, `0x0E0 + M`).
fn is_request_id(frame: &CanFrame) -> bool {
    !frame.is_extended() && matches!(frame.id() & !0x1f, GET_BASE | PUT_BASE) && frame.id() & 0x1f != 0
}

/// Several modules on one bus (CAN, or an RS232 line with addresses).
#[derive(Debug)]
pub struct PowerCubeBus {
    /// Sorted by id, ids unique.
    modules: Vec<Module>,
    rs232: rs232::Decoder,
    tracer: Option<Tracer>,
}

impl PowerCubeBus {
    /// Modules in id order; a repeated id keeps the first spec.
    pub fn new(specs: impl IntoIterator<Item = ModuleSpec>, now: Instant) -> Self {
        let mut modules: Vec<Module> = Vec::new();
        for spec in specs {
            if let Err(at) = modules.binary_search_by_key(&spec.id, |m| m.id()) {
                modules.insert(at, Module::new(spec, now));
            }
        }
        Self { modules, rs232: rs232::Decoder::new(), tracer: None }
    }

    pub fn set_tracer(&mut self, tracer: Option<Tracer>) {
        self.tracer = tracer;
    }

    /// Tells the tracer why module `m` does not answer `req`.
    fn unanswered(&self, m: u8, req: &Request) {
        let Some(trace) = self.tracer else { return };
        let why = match (req, self.module(m)) {
            (Request::GetExtended { param }, Some(module)) => match table::param(*param) {
                None => " (no such parameter)".to_string(),
                Some(d) if !table::firmware_has(module.spec().version, *param) => {
                    format!(" (firmware {} has no {})", table::version_text(module.spec().version), d.name)
                }
                Some(_) => String::new(),
            },
            (Request::SetExtended { param, .. }, Some(_)) => match table::param(*param) {
                None => " (no such parameter)".to_string(),
                Some(d) if !d.access.writable() => format!(" ({} is read-only)", d.name),
                Some(_) => String::new(),
            },
            _ => String::new(),
        };
        trace(&format!("module {m}: {req} not answered{why}"));
    }

    /// Tells the tracer that a frame to module `m` is no command it knows.
    fn not_understood(&self, m: u8, data: &[u8], e: &crate::proto::DecodeError) {
        if let (Some(trace), Some(_)) = (self.tracer, self.module(m)) {
            let hex: Vec<String> = data.iter().map(|b| format!("{b:02x}")).collect();
            trace(&format!("module {m}: [{}] not answered: {e}", hex.join(" ")));
        }
    }

    /// The bench of cli-contract.md: rotary modules 3 and 5, linear module 17
    /// (serial 12345, version 13592 as the `scan` example shows).
    pub fn contract_bench(now: Instant) -> Self {
        let id = |n| ModuleId::new(n).expect("valid module id");
        Self::new(
            [
                ModuleSpec::new(id(3), ModuleKind::Rotary),
                ModuleSpec::new(id(5), ModuleKind::Rotary),
                ModuleSpec::new(id(17), ModuleKind::Linear),
            ],
            now,
        )
    }

    /// A CAN frame from the host; acknowledges are appended to `out`.
    pub fn handle_can(&mut self, now: Instant, frame: &CanFrame, out: &mut Vec<CanFrame>) {
        match classify(frame) {
            Ok(Some(CanMessage::Request { module, request })) => {
                if let Some(m) = self.module_mut(module.get()) {
                    match m.handle_on(now, &request, Iface::Can) {
                        Some(resp) => out.push(ack_frame(module, &resp)),
                        None => self.unanswered(module.get(), &request),
                    }
                }
            }
            Err(e) if is_request_id(frame) => self.not_understood((frame.id() & 0x1f) as u8, frame.data(), &e),
            Ok(Some(CanMessage::Broadcast(b))) => self.broadcast(now, b, Iface::Can),
            // Other modules' acknowledges, foreign ids and garbage: a module
            // ignores what it cannot use.
            Ok(Some(CanMessage::Ack { .. })) | Ok(None) | Err(_) => {}
        }
    }

    /// RS232 bytes from the host, split anywhere; answers appended to `out`.
    pub fn handle_rs232(&mut self, now: Instant, bytes: &[u8], out: &mut Vec<u8>) {
        self.rs232.push(bytes);
        while let Some(frame) = self.rs232.next_frame() {
            let Ok(frame) = frame else { continue };
            if frame.dir != Direction::ToModule || frame.len_mismatch() {
                continue;
            }
            if frame.is_broadcast() {
                if let Ok(b) = Broadcast::decode(frame.payload.as_slice()) {
                    self.broadcast(now, b, Iface::Rs232);
                }
                continue;
            }
            let request = match frame.request() {
                Ok(r) => r,
                Err(e) => {
                    self.not_understood(frame.module, frame.payload.as_slice(), &e);
                    continue;
                }
            };
            if let Some(m) = self.module_mut(frame.module) {
                match m.handle_on(now, &request, Iface::Rs232) {
                    Some(resp) => rs232::encode_response(frame.module, &resp, out),
                    None => self.unanswered(frame.module, &request),
                }
            }
        }
    }

    fn broadcast(&mut self, now: Instant, b: Broadcast, iface: Iface) {
        if let (Some(trace), Broadcast::ChangeBaudrate(_)) = (self.tracer, b) {
            trace(&format!("broadcast {b} ignored (the simulated bus keeps its rate)"));
        }
        for m in &mut self.modules {
            m.broadcast_on(now, b, iface);
        }
    }

    /// Brings every module up to `now`.
    pub fn advance(&mut self, now: Instant) {
        for m in &mut self.modules {
            m.advance(now);
        }
    }

    pub fn module(&self, id: u8) -> Option<&Module> {
        self.modules.binary_search_by_key(&id, |m| m.id().get()).ok().map(|i| &self.modules[i])
    }

    pub fn module_mut(&mut self, id: u8) -> Option<&mut Module> {
        self.modules.binary_search_by_key(&id, |m| m.id().get()).ok().map(|i| &mut self.modules[i])
    }

    /// In id order.
    pub fn modules(&self) -> impl Iterator<Item = &Module> {
        self.modules.iter()
    }

    pub fn modules_mut(&mut self) -> impl Iterator<Item = &mut Module> {
        self.modules.iter_mut()
    }
}

/// `trip=`: a module that moves too long gets STATE_TOW_ERROR.
impl crate::sim::fault::Jams for PowerCubeBus {
    fn moving(&mut self, now: Instant) -> Vec<(u8, bool)> {
        self.advance(now);
        self.modules()
            .map(|m| (m.id().get(), m.cube_state() & crate::proto::powercube::flags::state::MOTION != 0))
            .collect()
    }

    fn jam(&mut self, _now: Instant, id: u8) {
        if let Some(m) = self.module_mut(id) {
            m.inject_error(crate::proto::powercube::flags::state::TOW_ERROR);
        }
    }
}
