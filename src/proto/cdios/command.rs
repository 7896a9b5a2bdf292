//! Typed Cdios 6168 commands. A [`Command`] only names a table row, a
//! selector and the field values; [`super::table::encode`] makes the bytes and
//! checks the manual's ranges, so the typed API and the table cannot drift.

use super::table::{self, CommandDef, DecodedCommand};
use super::transport;
use super::{Address, NodeId, ValidationError};
use crate::proto::CanFrame;

macro_rules! u8_enum {
    ($(#[$m:meta])* $name:ident { $($(#[$vm:meta])* $var:ident = $val:expr),+ $(,)? }) => {
        $(#[$m])*
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize)]
        #[serde(rename_all = "snake_case")]
        pub enum $name { $($(#[$vm])* $var = $val),+ }

        impl $name {
            pub const ALL: &'static [Self] = &[$(Self::$var),+];

            pub const fn to_u8(self) -> u8 {
                self as u8
            }

            pub fn from_u8(v: u8) -> Option<Self> {
                Self::ALL.iter().copied().find(|x| *x as u8 == v)
            }
        }
    };
}

u8_enum!(
    /// 16h: which of the two analog outputs.
    AnalogOutput { One = 1, Two = 2 }
);

u8_enum!(
    /// 21h selector.
    PositionSource {
        Current = 0,
        /// Latched by the latest SYNC.
        Latched = 1,
        /// Latest GOTO position / traject end point.
        Setpoint = 2,
    }
);

u8_enum!(
    /// 23h selectors 0..5.
    GotoMode {
        Absolute = 0,
        AbsoluteSync = 1,
        /// Relative to the current position.
        Relative = 2,
        RelativeSync = 3,
        /// Relative to the current setpoint (last GOTO position).
        SetpointRelative = 4,
        SetpointRelativeSync = 5,
    }
);

u8_enum!(
    /// 24h direction.
    Direction { Forward = 0, Reverse = 1 }
);

u8_enum!(
    /// 24h options.
    StartOption {
        MinimumSpeed = 0,
        Accelerate = 1,
        UntilEndSwitch = 2,
        ToSpeed = 3,
        UntilIndex = 4,
        Enable = 5,
        UntilIndexAndZero = 6,
    }
);

u8_enum!(
    /// 25h options. The manual lists 3 as reserved, yet status 2 bit 5 says a
    /// stop with option 3 releases the emergency stop: 3 is that.
    StopOption {
        DecelerateToMinimum = 0,
        DecelerateAndStop = 1,
        FastStop = 2,
        ReleaseEmergency = 3,
        ClearHold = 4,
        Disable = 5,
    }
);

u8_enum!(
    /// 26h selectors.
    StatusSelector { Status = 0, Speed = 1, SpeedError = 2 }
);

u8_enum!(
    /// Traject 0 or 1.
    Traject { Zero = 0, One = 1 }
);

u8_enum!(
    /// Speed change 1..3 of a traject.
    Step { First = 1, Second = 2, Third = 3 }
);

/// Which part of the servo configuration a 20h selector addresses.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum ServoPart {
    Speeds,
    Voltage,
    Encoder,
    Control,
    Inputs,
    TrajectEnd(Traject),
    TrajectInitialSpeed(Traject),
    TrajectChangePosition(Traject, Step),
    TrajectSpeed(Traject, Step),
}

impl ServoPart {
    /// The set selector; reading uses `selector() | 0x80`.
    pub const fn selector(self) -> u8 {
        const fn base(t: Traject) -> u8 {
            0x10 * (t as u8 + 1)
        }
        match self {
            Self::Speeds => 0,
            Self::Voltage => 1,
            Self::Encoder => 2,
            Self::Control => 3,
            Self::Inputs => 4,
            Self::TrajectEnd(t) => base(t),
            Self::TrajectInitialSpeed(t) => base(t) + 1,
            Self::TrajectChangePosition(t, s) => base(t) + 2 * s as u8,
            Self::TrajectSpeed(t, s) => base(t) + 2 * s as u8 + 1,
        }
    }

    pub fn from_selector(s: u8) -> Option<Self> {
        let traject = Traject::from_u8((s >> 4).wrapping_sub(1));
        Some(match (s >> 4, s & 0x0F) {
            (0, 0) => Self::Speeds,
            (0, 1) => Self::Voltage,
            (0, 2) => Self::Encoder,
            (0, 3) => Self::Control,
            (0, 4) => Self::Inputs,
            (1..=2, 0) => Self::TrajectEnd(traject?),
            (1..=2, 1) => Self::TrajectInitialSpeed(traject?),
            (1..=2, n @ (2 | 4 | 6)) => Self::TrajectChangePosition(traject?, Step::from_u8(n / 2)?),
            (1..=2, n @ (3 | 5 | 7)) => Self::TrajectSpeed(traject?, Step::from_u8(n / 2)?),
            _ => return None,
        })
    }

    /// Every part, in selector order.
    pub fn all() -> Vec<Self> {
        (0..=0x27).filter_map(Self::from_selector).collect()
    }
}

/// One 20h "Set Analog Servo motor configuration" message.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum ServoConfig {
    /// RPM, RPM, 0.1 s.
    Speeds {
        minimum_speed: u16,
        maximum_speed: u16,
        slope: u8,
    },
    /// mV.
    Voltage {
        maximum_voltage: u16,
        forward_end_switch: bool,
        reverse_end_switch: bool,
    },
    Encoder {
        pulses_per_revolution: u16,
        hold_on_enable: bool,
        auto_zero: bool,
        sin2_slope: bool,
    },
    Control {
        positioning_error: u16,
        gain_factor: u8,
        d_factor: u8,
        failsafe: u8,
    },
    Inputs {
        ready_input: bool,
        error_input: bool,
    },
    TrajectEnd {
        traject: Traject,
        end_position: i32,
        length: u8,
    },
    TrajectInitialSpeed {
        traject: Traject,
        speed: u16,
    },
    TrajectChangePosition {
        traject: Traject,
        step: Step,
        position: i32,
    },
    TrajectSpeed {
        traject: Traject,
        step: Step,
        speed: u16,
    },
}

impl ServoConfig {
    pub fn part(&self) -> ServoPart {
        match *self {
            Self::Speeds { .. } => ServoPart::Speeds,
            Self::Voltage { .. } => ServoPart::Voltage,
            Self::Encoder { .. } => ServoPart::Encoder,
            Self::Control { .. } => ServoPart::Control,
            Self::Inputs { .. } => ServoPart::Inputs,
            Self::TrajectEnd { traject, .. } => ServoPart::TrajectEnd(traject),
            Self::TrajectInitialSpeed { traject, .. } => ServoPart::TrajectInitialSpeed(traject),
            Self::TrajectChangePosition { traject, step, .. } => ServoPart::TrajectChangePosition(traject, step),
            Self::TrajectSpeed { traject, step, .. } => ServoPart::TrajectSpeed(traject, step),
        }
    }

    fn values(&self) -> Vec<(&'static str, i64)> {
        match *self {
            Self::Speeds { minimum_speed, maximum_speed, slope } => vec![
                ("minimum_speed", minimum_speed.into()),
                ("maximum_speed", maximum_speed.into()),
                ("slope", slope.into()),
            ],
            Self::Voltage { maximum_voltage, forward_end_switch, reverse_end_switch } => vec![
                ("maximum_voltage", maximum_voltage.into()),
                ("forward_end_switch", forward_end_switch.into()),
                ("reverse_end_switch", reverse_end_switch.into()),
            ],
            Self::Encoder { pulses_per_revolution, hold_on_enable, auto_zero, sin2_slope } => vec![
                ("pulses_per_revolution", pulses_per_revolution.into()),
                ("hold_on_enable", hold_on_enable.into()),
                ("auto_zero", auto_zero.into()),
                ("slope_profile", sin2_slope.into()),
            ],
            Self::Control { positioning_error, gain_factor, d_factor, failsafe } => vec![
                ("positioning_error", positioning_error.into()),
                ("gain_factor", gain_factor.into()),
                ("d_factor", d_factor.into()),
                ("failsafe", failsafe.into()),
            ],
            Self::Inputs { ready_input, error_input } => {
                vec![("ready_input", ready_input.into()), ("error_input", error_input.into())]
            }
            Self::TrajectEnd { end_position, length, .. } => {
                vec![("end_position", end_position.into()), ("length", length.into())]
            }
            Self::TrajectInitialSpeed { speed, .. } => vec![("initial_speed", speed.into())],
            Self::TrajectChangePosition { position, .. } => vec![("change_position", position.into())],
            Self::TrajectSpeed { speed, .. } => vec![("speed", speed.into())],
        }
    }

    /// Builds the configuration of `part` from field values (a decoded set
    /// command or a read reply), checking the manual's ranges.
    pub fn from_values(part: ServoPart, get: impl Fn(&str) -> Option<i64>) -> Result<Self, ValidationError> {
        let row = table::command_for(table::SERVO_CONFIGURATION, part.selector())
            .ok_or(ValidationError::Selector { command: "set_servo", selector: part.selector() })?;
        let v = Values { def: row, get: &get };
        Ok(match part {
            ServoPart::Speeds => Self::Speeds {
                minimum_speed: v.int("minimum_speed")?,
                maximum_speed: v.int("maximum_speed")?,
                slope: v.int("slope")?,
            },
            ServoPart::Voltage => Self::Voltage {
                maximum_voltage: v.int("maximum_voltage")?,
                forward_end_switch: v.flag("forward_end_switch")?,
                reverse_end_switch: v.flag("reverse_end_switch")?,
            },
            ServoPart::Encoder => Self::Encoder {
                pulses_per_revolution: v.int("pulses_per_revolution")?,
                hold_on_enable: v.flag("hold_on_enable")?,
                auto_zero: v.flag("auto_zero")?,
                sin2_slope: v.flag("slope_profile")?,
            },
            ServoPart::Control => Self::Control {
                positioning_error: v.int("positioning_error")?,
                gain_factor: v.int("gain_factor")?,
                d_factor: v.int("d_factor")?,
                failsafe: v.int("failsafe")?,
            },
            ServoPart::Inputs => {
                Self::Inputs { ready_input: v.flag("ready_input")?, error_input: v.flag("error_input")? }
            }
            ServoPart::TrajectEnd(traject) => {
                Self::TrajectEnd { traject, end_position: v.int("end_position")?, length: v.int("length")? }
            }
            ServoPart::TrajectInitialSpeed(traject) => {
                Self::TrajectInitialSpeed { traject, speed: v.int("initial_speed")? }
            }
            ServoPart::TrajectChangePosition(traject, step) => {
                Self::TrajectChangePosition { traject, step, position: v.int("change_position")? }
            }
            ServoPart::TrajectSpeed(traject, step) => Self::TrajectSpeed { traject, step, speed: v.int("speed")? },
        })
    }

    /// The configuration carried by a 20h read reply.
    pub fn from_reply(reply: &table::DecodedReply) -> Result<Self, ValidationError> {
        let part = ServoPart::from_selector(reply.selector & 0x7F)
            .filter(|_| reply.selector & 0x80 != 0)
            .ok_or(ValidationError::Selector { command: "read_servo", selector: reply.selector })?;
        Self::from_values(part, |k| reply.get(k))
    }
}

/// 27h timers byte: position and speed event intervals (codes 0..7, see
/// [`table::TIMER_INTERVALS_MS`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, serde::Serialize)]
pub struct Timers {
    pub position_interval: u8,
    pub position_on_change: bool,
    pub speed_interval: u8,
    pub speed_on_change: bool,
}

impl Timers {
    pub fn interval_ms(code: u8) -> Option<f64> {
        table::TIMER_INTERVALS_MS.get(code as usize).copied()
    }
}

/// A Cdios 6168 (or controller) command.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Command {
    /// 01h to the controller, selector 0..=24.
    Identify {
        selector: u8,
    },
    /// 05h; `defaults`: reset to the defaults first.
    StoreConfiguration {
        defaults: bool,
    },
    /// 10h selector 0/1; bit 0 = output 1.
    SetDigitalOutputs {
        latched: bool,
        outputs: u8,
    },
    /// 10h selector 80h (answered with 11h).
    GetDigitalOutputs,
    /// 16h, mV.
    SetAnalogOutput {
        output: AnalogOutput,
        latched: bool,
        millivolts: i16,
    },
    ReadAnalogOutput {
        output: AnalogOutput,
    },
    SetServoConfig(ServoConfig),
    ReadServoConfig(ServoPart),
    ReadPosition(PositionSource),
    SetPosition {
        position: i32,
    },
    Goto {
        mode: GotoMode,
        position: i32,
    },
    GotoTraject {
        traject: Traject,
        sync: bool,
    },
    /// 23h selector 8; 0 = the configured maximum speed.
    SetNextGotoSpeed {
        speed: u16,
    },
    /// 23h selector 9.
    SetSpeedChangePosition {
        position: i32,
    },
    /// 23h selector 10.
    ChangeGotoSpeed {
        speed: u16,
    },
    Start {
        sync: bool,
        direction: Direction,
        option: StartOption,
        motor_speed: u16,
    },
    Stop {
        sync: bool,
        option: StopOption,
    },
    ReadStatus(StatusSelector),
    SetEventMask {
        masks: [u8; 4],
        timers: Timers,
    },
    ReadEventMask,
}

impl Command {
    /// Row key, selector and field values.
    fn parts(&self) -> (&'static str, u8, Vec<(&'static str, i64)>) {
        let sync = |s: bool| u8::from(s);
        match *self {
            Self::Identify { selector } => {
                (if selector <= 7 { "identify" } else { "identify_table" }, selector, vec![])
            }
            Self::StoreConfiguration { defaults } => ("store_configuration", u8::from(defaults), vec![]),
            Self::SetDigitalOutputs { latched, outputs } => {
                ("set_digital_outputs", sync(latched), vec![("outputs", outputs.into())])
            }
            Self::GetDigitalOutputs => ("get_digital_outputs", 0x80, vec![]),
            Self::SetAnalogOutput { output, latched, millivolts } => {
                let s = if output == AnalogOutput::One { 0x00 } else { 0x10 } | sync(latched);
                ("set_analog_output", s, vec![("value", millivolts.into())])
            }
            Self::ReadAnalogOutput { output } => {
                ("read_analog_output", if output == AnalogOutput::One { 0x80 } else { 0x90 }, vec![])
            }
            Self::SetServoConfig(c) => (servo_key(c.part(), false), c.part().selector(), c.values()),
            Self::ReadServoConfig(p) => (servo_key(p, true), p.selector() | 0x80, vec![]),
            Self::ReadPosition(s) => ("read_position", s.to_u8(), vec![]),
            Self::SetPosition { position } => ("set_position", 0, vec![("position", position.into())]),
            Self::Goto { mode, position } => ("goto", mode.to_u8(), vec![("position", position.into())]),
            Self::GotoTraject { traject, sync: s } => {
                ("goto_traject", 6 + sync(s), vec![("traject", traject.to_u8().into())])
            }
            Self::SetNextGotoSpeed { speed } => ("goto_next_speed", 8, vec![("speed", speed.into())]),
            Self::SetSpeedChangePosition { position } => {
                ("goto_speed_change_position", 9, vec![("position", position.into())])
            }
            Self::ChangeGotoSpeed { speed } => ("goto_change_speed", 10, vec![("speed", speed.into())]),
            Self::Start { sync: s, direction, option, motor_speed } => (
                "start",
                sync(s),
                vec![
                    ("direction", direction.to_u8().into()),
                    ("option", option.to_u8().into()),
                    ("motor_speed", motor_speed.into()),
                ],
            ),
            Self::Stop { sync: s, option } => ("stop", sync(s), vec![("option", option.to_u8().into())]),
            Self::ReadStatus(s) => (
                match s {
                    StatusSelector::Status => "read_status",
                    StatusSelector::Speed => "read_speed",
                    StatusSelector::SpeedError => "read_speed_error",
                },
                s.to_u8(),
                vec![],
            ),
            Self::SetEventMask { masks, timers } => (
                "set_event_mask",
                0,
                vec![
                    ("mask1", masks[0].into()),
                    ("mask2", masks[1].into()),
                    ("mask3", masks[2].into()),
                    ("mask4", masks[3].into()),
                    ("position_interval", timers.position_interval.into()),
                    ("position_on_change", timers.position_on_change.into()),
                    ("speed_interval", timers.speed_interval.into()),
                    ("speed_on_change", timers.speed_on_change.into()),
                ],
            ),
            Self::ReadEventMask => ("read_event_mask", 0x80, vec![]),
        }
    }

    /// The table row this command uses.
    pub fn def(&self) -> &'static CommandDef {
        table::command(self.parts().0).expect("every Command names a table row (tested)")
    }

    pub fn selector(&self) -> u8 {
        self.parts().1
    }

    /// The code of the normal answer (11h for [`Command::GetDigitalOutputs`]).
    pub fn reply_code(&self) -> u8 {
        self.def().reply.code
    }

    /// The 8 data bytes, after the manual's range checks.
    pub fn encode(&self, address: Address) -> Result<[u8; 8], ValidationError> {
        let (key, selector, values) = self.parts();
        let def = table::command(key).ok_or(ValidationError::UnknownField { command: "command", field: key.into() })?;
        table::encode(def, address, selector, &values)
    }

    /// The CAN frame to `node`.
    pub fn frame(&self, node: NodeId, address: Address) -> Result<CanFrame, ValidationError> {
        Ok(transport::command_frame(node, &self.encode(address)?))
    }

    /// Reads a command back from its data bytes (what a module receives),
    /// rejecting what the module would reject by range.
    pub fn decode(data: &[u8]) -> Result<(Address, Self), ValidationError> {
        let d = table::decode_command(data)?;
        d.validate()?;
        Ok((d.address, Self::from_decoded(&d)?))
    }

    fn from_decoded(d: &DecodedCommand) -> Result<Self, ValidationError> {
        let get = |k: &str| d.get(k);
        let v = Values { def: d.def, get: &get };
        let s = d.selector;
        let bad_selector = || ValidationError::Selector { command: d.def.key, selector: s };
        let sync = s & 1 == 1;
        Ok(match d.def.key {
            "identify" | "identify_table" => Self::Identify { selector: s },
            "store_configuration" => Self::StoreConfiguration { defaults: s == 1 },
            "set_digital_outputs" => Self::SetDigitalOutputs { latched: sync, outputs: v.int("outputs")? },
            "get_digital_outputs" => Self::GetDigitalOutputs,
            "set_analog_output" => Self::SetAnalogOutput {
                output: if s & 0x10 == 0 { AnalogOutput::One } else { AnalogOutput::Two },
                latched: sync,
                millivolts: v.int("value")?,
            },
            "read_analog_output" => {
                Self::ReadAnalogOutput { output: if s == 0x80 { AnalogOutput::One } else { AnalogOutput::Two } }
            }
            k if k.starts_with("set_servo_") || k.starts_with("set_traject_") => {
                let part = ServoPart::from_selector(s).ok_or_else(bad_selector)?;
                Self::SetServoConfig(ServoConfig::from_values(part, get)?)
            }
            k if k.starts_with("read_servo_") || k.starts_with("read_traject_") => {
                Self::ReadServoConfig(ServoPart::from_selector(s & 0x7F).ok_or_else(bad_selector)?)
            }
            "read_position" => Self::ReadPosition(PositionSource::from_u8(s).ok_or_else(bad_selector)?),
            "set_position" => Self::SetPosition { position: v.int("position")? },
            "goto" => Self::Goto { mode: GotoMode::from_u8(s).ok_or_else(bad_selector)?, position: v.int("position")? },
            "goto_traject" => Self::GotoTraject { traject: v.enumerated("traject", Traject::from_u8)?, sync: s == 7 },
            "goto_next_speed" => Self::SetNextGotoSpeed { speed: v.int("speed")? },
            "goto_speed_change_position" => Self::SetSpeedChangePosition { position: v.int("position")? },
            "goto_change_speed" => Self::ChangeGotoSpeed { speed: v.int("speed")? },
            "start" => Self::Start {
                sync,
                direction: v.enumerated("direction", Direction::from_u8)?,
                option: v.enumerated("option", StartOption::from_u8)?,
                motor_speed: v.int("motor_speed")?,
            },
            "stop" => Self::Stop { sync, option: v.enumerated("option", StopOption::from_u8)? },
            "read_status" | "read_speed" | "read_speed_error" => {
                Self::ReadStatus(StatusSelector::from_u8(s).ok_or_else(bad_selector)?)
            }
            "set_event_mask" => Self::SetEventMask {
                masks: [v.int("mask1")?, v.int("mask2")?, v.int("mask3")?, v.int("mask4")?],
                timers: Timers {
                    position_interval: v.int("position_interval")?,
                    position_on_change: v.flag("position_on_change")?,
                    speed_interval: v.int("speed_interval")?,
                    speed_on_change: v.flag("speed_on_change")?,
                },
            },
            "read_event_mask" => Self::ReadEventMask,
            _ => return Err(bad_selector()),
        })
    }
}

fn servo_key(part: ServoPart, read: bool) -> &'static str {
    match (part, read) {
        (ServoPart::Speeds, false) => "set_servo_speeds",
        (ServoPart::Voltage, false) => "set_servo_voltage",
        (ServoPart::Encoder, false) => "set_servo_encoder",
        (ServoPart::Control, false) => "set_servo_control",
        (ServoPart::Inputs, false) => "set_servo_inputs",
        (ServoPart::TrajectEnd(_), false) => "set_traject_end",
        (ServoPart::TrajectInitialSpeed(_), false) => "set_traject_initial_speed",
        (ServoPart::TrajectChangePosition(..), false) => "set_traject_change_position",
        (ServoPart::TrajectSpeed(..), false) => "set_traject_speed",
        (ServoPart::Speeds, true) => "read_servo_speeds",
        (ServoPart::Voltage, true) => "read_servo_voltage",
        (ServoPart::Encoder, true) => "read_servo_encoder",
        (ServoPart::Control, true) => "read_servo_control",
        (ServoPart::Inputs, true) => "read_servo_inputs",
        (ServoPart::TrajectEnd(_), true) => "read_traject_end",
        (ServoPart::TrajectInitialSpeed(_), true) => "read_traject_initial_speed",
        (ServoPart::TrajectChangePosition(..), true) => "read_traject_change_position",
        (ServoPart::TrajectSpeed(..), true) => "read_traject_speed",
    }
}

/// Field lookups that turn raw values into typed ones without panicking.
struct Values<'a> {
    def: &'static CommandDef,
    get: &'a dyn Fn(&str) -> Option<i64>,
}

impl Values<'_> {
    fn raw(&self, key: &'static str) -> Result<(i64, &'static table::Field), ValidationError> {
        let missing = ValidationError::MissingField { command: self.def.key, field: key };
        let field = self.def.field(key).or_else(|| self.def.reply.fields.iter().find(|f| f.key == key));
        let field = field.ok_or(missing.clone())?;
        let v = (self.get)(key).ok_or(missing)?;
        field.check(v)?;
        Ok((v, field))
    }

    fn int<T: TryFrom<i64>>(&self, key: &'static str) -> Result<T, ValidationError> {
        let (v, f) = self.raw(key)?;
        T::try_from(v).map_err(|_| ValidationError::OutOfRange { field: key, value: v, min: f.min, max: f.max })
    }

    fn flag(&self, key: &'static str) -> Result<bool, ValidationError> {
        match self.raw(key)? {
            (0, _) => Ok(false),
            (1, _) => Ok(true),
            (v, _) => Err(ValidationError::OutOfRange { field: key, value: v, min: 0, max: 1 }),
        }
    }

    fn enumerated<T>(&self, key: &'static str, from: fn(u8) -> Option<T>) -> Result<T, ValidationError> {
        let (v, f) = self.raw(key)?;
        u8::try_from(v).ok().and_then(from).ok_or(ValidationError::OutOfRange {
            field: key,
            value: v,
            min: f.min,
            max: f.max,
        })
    }
}
