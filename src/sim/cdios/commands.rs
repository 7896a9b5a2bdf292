//! What a 6168 does with each command of the table: checks in the order of
//! the manual's error tables, then the action and the reply.

use super::motor::{reply, Goto, Latched, Motion, Motor6168, RunKind};
use crate::proto::cdios::table::{self, DecodedCommand};
use crate::proto::cdios::ValidationError;

/// What the module answers.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Outcome {
    /// The normal reply; `always`: sent even when 'Confirm' is 0.
    Reply { data: [u8; 8], always: bool },
    /// An error reply: general code and the command's status bits.
    Error { general: u8, status: [u8; 2] },
    /// 05h accepted: the node programs the EEPROM, then replies.
    Store { defaults: bool },
}

/// The error status bits of one command, set by the table's flag names so
/// that bit positions live only in the table.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) struct Bits {
    code: u8,
    pub status: [u8; 2],
}

impl Bits {
    pub fn new(code: u8) -> Self {
        Self { code, status: [0; 2] }
    }

    /// Sets the flag `name` of this command's error table; `false` if the table has none.
    pub fn set(&mut self, name: &str) -> bool {
        match table::error_bits(self.code).iter().find(|f| f.name == name) {
            Some(f) if (1..=2).contains(&f.byte) => {
                self.status[usize::from(f.byte - 1)] |= 1 << f.bit;
                true
            }
            _ => false,
        }
    }

    pub fn any(&self) -> bool {
        self.status != [0, 0]
    }

    fn outcome(self) -> Outcome {
        Outcome::Error { general: 0, status: self.status }
    }
}

/// The general error for a command form the module does not support
/// (a selector outside the table where the command has no selector bit).
pub(super) const GENERAL_NOT_SUPPORTED: u8 = 6;

/// The error flag of a field out of range (20h prints two meanings on some bits).
fn range_flag(code: u8, key: &str) -> String {
    match (code, key) {
        (table::DIGITAL_OUTPUTS, _) => "DATA_OUT_OF_RANGE".into(),
        (table::ANALOG_OUTPUTS, _) => "VALUE_OUT_OF_RANGE".into(),
        (_, "hold_on_enable" | "ready_input") => "HOLD_ON_ENABLE_OR_READY_OUT_OF_RANGE".into(),
        (_, "auto_zero" | "error_input") => "AUTOZERO_OR_ERROR_OUT_OF_RANGE".into(),
        (table::SERVO_CONFIGURATION, "end_position" | "length" | "initial_speed" | "change_position" | "speed") => {
            "TRAJECT_OUT_OF_RANGE".into()
        }
        _ => format!("{}_OUT_OF_RANGE", key.to_ascii_uppercase()),
    }
}

/// Sets the range flag of every field of `d` outside the manual's range, except `skip`.
fn check_ranges(d: &DecodedCommand, bits: &mut Bits, skip: &[&str]) {
    for (v, f) in d.fields.iter().zip(d.def.fields) {
        if !f.in_range(v.raw) && !skip.contains(&f.key) {
            bits.set(&range_flag(d.def.code, f.key));
        }
    }
}

fn ack(key: &str, module: u8, selector: u8) -> Outcome {
    match reply(key, module, selector, &[]) {
        Some(data) => Outcome::Reply { data, always: false },
        None => Outcome::Error { general: GENERAL_NOT_SUPPORTED, status: [0; 2] },
    }
}

fn read(key: &str, module: u8, selector: u8, values: &[(&str, i64)]) -> Outcome {
    match reply(key, module, selector, values) {
        Some(data) => Outcome::Reply { data, always: true },
        None => Outcome::Error { general: GENERAL_NOT_SUPPORTED, status: [0; 2] },
    }
}

impl Motor6168 {
    /// A command addressed to this module (code known to the table).
    pub(super) fn command(&mut self, data: &[u8; 8]) -> Outcome {
        let code = data[0];
        let d = match table::decode_command(data) {
            Ok(d) => d,
            Err(ValidationError::Selector { .. }) => {
                let mut bits = Bits::new(code);
                return if bits.set("SELECTOR_OUT_OF_RANGE") {
                    bits.outcome()
                } else {
                    Outcome::Error { general: GENERAL_NOT_SUPPORTED, status: [0; 2] }
                };
            }
            Err(_) => return Outcome::Error { general: 3, status: [0; 2] },
        };
        let (id, sel) = (self.id, d.selector);
        let get = |k: &str| d.get(k).unwrap_or(0);
        let mut bits = Bits::new(code);
        let out = match d.def.key {
            "store_configuration" => {
                // The manual gives 05h no error table: bit 0 is our "motor
                // enabled" (it must be disabled), bit 1 a wrong "CDS" key.
                if self.enabled {
                    bits.status[0] |= 0x01;
                }
                if d.fields.iter().zip(d.def.fields).any(|(v, f)| !f.in_range(v.raw)) {
                    bits.status[0] |= 0x02;
                }
                if bits.any() {
                    return bits.outcome();
                }
                return Outcome::Store { defaults: sel == 1 };
            }
            "set_digital_outputs" => {
                check_ranges(&d, &mut bits, &[]);
                if !bits.any() {
                    let v = get("outputs") as u8;
                    if sel == 1 {
                        self.latched_digital = Some(v);
                    } else {
                        self.digital = v;
                    }
                }
                ack(d.def.key, id, sel)
            }
            "get_digital_outputs" => read(d.def.key, id, sel, &[("state", self.digital.into())]),
            "set_analog_output" => {
                check_ranges(&d, &mut bits, &[]);
                let index = usize::from(sel >> 4);
                if index == 0 && self.enabled {
                    bits.set("MOTOR_ENABLED");
                }
                if !bits.any() {
                    let v = get("value") as i16;
                    if sel & 1 == 1 {
                        self.latched_analog[index] = Some(v);
                    } else {
                        self.analog[index] = v;
                    }
                }
                ack(d.def.key, id, sel)
            }
            "read_analog_output" => {
                let v = self.analog_outputs()[usize::from(sel == 0x90)];
                read(d.def.key, id, sel, &[("value", v.into())])
            }
            k if k.starts_with("set_servo_") || k.starts_with("set_traject_") => {
                if self.running() {
                    bits.set("MOTOR_RUNNING");
                }
                check_ranges(&d, &mut bits, &[]);
                if sel == 0 && get("minimum_speed") > get("maximum_speed") {
                    bits.set("MAXIMUM_SPEED_OUT_OF_RANGE");
                }
                if !bits.any() {
                    let values: Vec<(&'static str, i64)> = d.fields.iter().map(|v| (v.key, v.raw)).collect();
                    self.store.set(sel, &values);
                    self.config_changed();
                }
                ack(d.def.key, id, sel)
            }
            k if k.starts_with("read_servo_") || k.starts_with("read_traject_") => {
                let values = self.store.values(sel & 0x7F).map(<[_]>::to_vec).unwrap_or_default();
                read(d.def.key, id, sel, &values)
            }
            "read_position" => read(d.def.key, id, sel, &[("position", self.read_position(sel).into())]),
            "set_position" => {
                if self.running() {
                    bits.set("MOTOR_RUNNING");
                } else {
                    self.set_position(get("position") as i32);
                }
                ack(d.def.key, id, sel)
            }
            "goto" | "goto_traject" | "goto_next_speed" | "goto_speed_change_position" | "goto_change_speed" => {
                check_ranges(&d, &mut bits, &[]);
                if !bits.any() {
                    bits = self.goto(sel, get("position") as i32, get("traject") as u8, get("speed") as u16, false);
                }
                ack(d.def.key, id, sel)
            }
            "start" => {
                let option = get("option");
                let skip: &[&str] = if option == 3 { &[] } else { &["motor_speed"] };
                check_ranges(&d, &mut bits, skip);
                if !bits.any() {
                    bits = self.start(sel, get("direction") as u8, option as u8, get("motor_speed") as u16, false);
                }
                ack(d.def.key, id, sel)
            }
            "stop" => {
                check_ranges(&d, &mut bits, &[]);
                if !bits.any() {
                    bits = self.stop(sel, get("option") as u8, false);
                }
                ack(d.def.key, id, sel)
            }
            "read_status" => {
                let s = self.take_status();
                Outcome::Reply { data: self.status_reply(s), always: true }
            }
            "read_speed" => read(d.def.key, id, sel, &[("motor_speed", self.speed_word().into())]),
            "read_speed_error" => read(
                d.def.key,
                id,
                sel,
                &[("motor_speed", self.speed_word().into()), ("rpm_error", self.rpm_error_word().into())],
            ),
            "set_event_mask" => {
                self.set_events([data[3], data[4], data[5], data[6]], data[7]);
                ack(d.def.key, id, sel)
            }
            "read_event_mask" => {
                let t = self.timers;
                let values = [
                    ("mask1", i64::from(self.mask[0])),
                    ("mask2", i64::from(self.mask[1])),
                    ("mask3", i64::from(self.mask[2])),
                    ("mask4", i64::from(self.mask[3])),
                    ("position_interval", i64::from(t & 0x07)),
                    ("position_on_change", i64::from((t >> 3) & 1)),
                    ("speed_interval", i64::from((t >> 4) & 0x07)),
                    ("speed_on_change", i64::from(t >> 7)),
                ];
                read(d.def.key, id, sel, &values)
            }
            _ => Outcome::Error { general: 3, status: [0; 2] },
        };
        self.mark_dirty();
        if bits.any() {
            bits.outcome()
        } else {
            out
        }
    }

    /// A running motion a new GOTO may interrupt: a goto, not a traject, with the linear slope.
    fn interruptible(&self) -> bool {
        matches!(&self.motion, Motion::Goto(g) if !g.traject) && !self.p.sin2
    }

    /// Motion a GOTO / START refuses with "motor is running" (hold corrections do not count).
    fn busy(&self) -> bool {
        matches!(self.motion, Motion::Run(_) | Motion::Goto(_))
    }

    /// 23h, any selector. `at_sync`: the latched command runs now.
    pub(super) fn goto(&mut self, sel: u8, value: i32, traject: u8, speed: u16, at_sync: bool) -> Bits {
        let mut bits = Bits::new(table::GOTO);
        match sel {
            8 => {
                self.next_speed = speed;
                return bits;
            }
            9 | 10 => {
                match &self.motion {
                    Motion::Goto(_) if self.interruptible() => {}
                    Motion::Goto(_) => {
                        bits.set("MOTOR_RUNNING");
                    }
                    _ => {
                        bits.set("NO_GOTO_RUNNING");
                    }
                }
                if bits.any() {
                    return bits;
                }
                let (pos, dir) = (self.pos_f(), self.dir());
                let next = self.p.clamp_speed(self.next_speed);
                let now_speed = self.p.clamp_speed(speed);
                if let Motion::Goto(g) = &mut self.motion {
                    if sel == 10 || (f64::from(value) - pos) * dir <= 0.0 {
                        g.cruise = if sel == 10 { now_speed } else { next };
                        g.braking = false;
                        g.changes.clear();
                    } else {
                        g.changes = vec![(value, next)];
                    }
                }
                return bits;
            }
            _ => {}
        }
        if !self.enabled {
            bits.set("MOTOR_NOT_ENABLED");
        }
        if self.emergency_blocked() {
            bits.set("EMERGENCY");
        }
        let is_traject = sel == 6 || sel == 7;
        if is_traject {
            if self.busy() {
                bits.set("MOTOR_RUNNING");
            }
            if self.p.sin2 {
                bits.set("TRAJECT_NEEDS_LINEAR_SLOPE");
            }
            if self.p.trajects.get(usize::from(traject)).is_none_or(|t| t.length == 0) {
                bits.set("TRAJECT_OUT_OF_RANGE");
            }
        } else if self.busy() && !self.interruptible() {
            bits.set("MOTOR_RUNNING");
        }
        if bits.any() {
            return bits;
        }
        if sel % 2 == 1 && !at_sync {
            self.latched_motion =
                Some(if is_traject { Latched::Traject(traject) } else { Latched::Goto { selector: sel - 1, value } });
            return bits;
        }
        if is_traject {
            let t = self.p.trajects[usize::from(traject)];
            let base = self.setpoint;
            let steps = usize::from(t.length.clamp(1, 4) - 1);
            let changes = (0..steps)
                .map(|i| (base.saturating_add(t.change_positions[i]), self.p.clamp_speed(t.speeds[i])))
                .collect();
            self.begin_goto(base.saturating_add(t.end_position), self.p.clamp_speed(t.initial_speed), changes, true);
        } else {
            let target = match sel & !1 {
                2 => self.position().saturating_add(value),
                4 => self.setpoint.saturating_add(value),
                _ => value,
            };
            self.begin_goto(target, self.p.clamp_speed(self.next_speed), Vec::new(), false);
        }
        bits
    }

    fn begin_goto(&mut self, target: i32, cruise: f64, changes: Vec<(i32, f64)>, traject: bool) {
        self.setpoint = target;
        if let Motion::Goto(g) = &mut self.motion {
            *g = Goto { target, cruise, changes, traject, braking: false };
            return;
        }
        let diff = f64::from(target) - self.pos_f();
        if diff.abs() < 0.5 {
            self.stop_now(true);
            self.setpoint = target;
            return;
        }
        self.start_moving(diff.signum(), Motion::Goto(Goto { target, cruise, changes, traject, braking: false }));
    }

    /// 24h.
    pub(super) fn start(&mut self, sel: u8, direction: u8, option: u8, speed: u16, at_sync: bool) -> Bits {
        let mut bits = Bits::new(table::START);
        let dir = if direction == 1 { -1.0 } else { 1.0 };
        let running_dir = match self.status()[0] & 0x03 {
            0x01 => Some(1.0),
            0x02 => Some(-1.0),
            _ => None,
        };
        if option == 5 {
            if self.emergency_blocked() {
                bits.set("EMERGENCY");
            }
            if self.busy() {
                bits.set("MOTOR_RUNNING");
            }
        } else {
            if !self.enabled {
                bits.set("MOTOR_NOT_ENABLED");
            }
            if self.emergency_blocked() {
                bits.set("EMERGENCY");
            }
            if self.busy() {
                let may = match (option, &self.motion) {
                    (1, Motion::Run(RunKind::Minimum)) => true,
                    (3, Motion::Run(RunKind::EndSwitch)) | (3, Motion::Goto(_)) => false,
                    (3, Motion::Run(_)) => true,
                    _ => false,
                };
                if !may {
                    bits.set("MOTOR_RUNNING");
                } else if running_dir.is_some_and(|r| r != dir) {
                    bits.set("RUNNING_OPPOSITE_DIRECTION");
                }
            }
            let checked = if dir > 0.0 { self.p.forward_check } else { self.p.reverse_check };
            if self.switch_towards(dir) && (checked || option == 2) {
                bits.set("END_SWITCH_ACTIVE");
            }
        }
        if bits.any() {
            return bits;
        }
        if sel == 1 && !at_sync {
            self.latched_motion = Some(Latched::Start { direction, option, speed });
            return bits;
        }
        self.latches.stopped_forward = false;
        self.latches.stopped_reverse = false;
        let run = match option {
            5 => {
                self.enabled = true;
                self.latches.does_not_run = false;
                self.latches.wrong_direction = false;
                self.setpoint = self.position();
                self.hold = self.p.hold_on_enable;
                self.mark_dirty();
                return bits;
            }
            0 => RunKind::Minimum,
            1 => RunKind::Maximum,
            2 => RunKind::EndSwitch,
            3 if speed == 0 => {
                if self.busy() {
                    self.motion = Motion::Run(RunKind::Stopping { hold: self.p.hold_on_enable });
                }
                return bits;
            }
            3 => RunKind::ToSpeed(f64::from(speed).clamp(self.p.min_rpm, self.p.max_rpm)),
            4 => RunKind::Index,
            _ => RunKind::IndexAndZero,
        };
        self.start_moving(dir, Motion::Run(run));
        bits
    }

    /// 25h.
    pub(super) fn stop(&mut self, sel: u8, option: u8, at_sync: bool) -> Bits {
        let mut bits = Bits::new(table::STOP);
        match option {
            3 => {
                if self.inputs.emergency
                    || (self.p.error_check && self.inputs.error)
                    || (self.p.ready_check && !self.inputs.ready)
                {
                    bits.set("EMERGENCY");
                }
            }
            5 => {}
            _ => {
                if self.latches.emergency_stop {
                    bits.set("EMERGENCY");
                }
                if !self.enabled {
                    bits.set("MOTOR_NOT_ENABLED");
                }
                match option {
                    4 if self.busy() => {
                        bits.set("MOTOR_RUNNING");
                    }
                    0..=2 if !self.busy() => {
                        bits.set("MOTOR_NOT_RUNNING");
                    }
                    _ => {}
                }
            }
        }
        if bits.any() {
            return bits;
        }
        if sel == 1 && !at_sync {
            self.latched_motion = Some(Latched::Stop { option });
            return bits;
        }
        let was_goto = matches!(self.motion, Motion::Goto(_));
        let hold = self.p.hold_on_enable || was_goto;
        match option {
            0 => self.motion = Motion::Run(RunKind::Minimum),
            1 => self.motion = Motion::Run(RunKind::Stopping { hold }),
            2 => self.stop_now(hold),
            3 => {
                self.latches.emergency_stop = false;
                self.latches.watchdog = false;
                self.latches.error_or_ready = false;
            }
            4 => self.hold = false,
            _ => self.halt_disable(),
        }
        self.mark_dirty();
        bits
    }

    /// A SYNC pulse: latched outputs and motion take effect, the position is latched.
    pub(super) fn sync(&mut self) {
        self.latched_position = self.position();
        if let Some(v) = self.latched_digital.take() {
            self.digital = v;
        }
        for i in 0..2 {
            if let Some(v) = self.latched_analog[i].take() {
                if i == 1 || !self.enabled {
                    self.analog[i] = v;
                }
            }
        }
        // Checked again now; a latched command the state no longer allows is dropped.
        match self.latched_motion.take() {
            Some(Latched::Goto { selector, value }) => {
                self.goto(selector, value, 0, 0, true);
            }
            Some(Latched::Traject(t)) => {
                self.goto(6, 0, t, 0, true);
            }
            Some(Latched::Start { direction, option, speed }) => {
                self.start(0, direction, option, speed, true);
            }
            Some(Latched::Stop { option }) => {
                self.stop(0, option, true);
            }
            None => {}
        }
        self.mark_dirty();
    }

    /// Back to the defaults (05h selector 1).
    pub(super) fn load_defaults(&mut self) {
        self.store = super::config::ServoStore::defaults();
        self.config_changed();
    }

    /// The current configuration becomes what a reset restores.
    pub(super) fn commit_eeprom(&mut self) {
        self.eeprom = self.store.clone();
    }
}
