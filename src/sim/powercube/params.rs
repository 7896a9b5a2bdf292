//! GetExtended / SetExtended on a simulated module. The wire type of every
//! answer comes from `table::PARAMS`; this file only says what each
//! parameter means.

use super::module::{limit, Module, SERVO_CYCLE_S};
use crate::proto::powercube::flags::{config, dio_setup, setup};
use crate::proto::powercube::frame::Value;
use crate::proto::powercube::table::{self, ids, ParamType};

/// Simulated supplies and housing temperature.
pub const LOGIC_SUPPLY_V: f64 = 24.0;
pub const MOTOR_SUPPLY_V: f64 = 48.0;
pub const TEMPERATURE_C: f64 = 35.0;
/// Scale of the ActRaw* values: 0.1 V, 0.1 degC and 0.01 A per digit.
pub const VOLT_PER_DIGIT: f64 = 0.1;
pub const DEGC_PER_DIGIT: f64 = 0.1;
pub const AMP_PER_DIGIT: f64 = 0.01;
/// DC bus current drawn by the electronics at rest.
pub const IDLE_BUS_CURRENT_A: f64 = 0.15;

/// A parameter's value before it is put in its wire type.
enum Num {
    F(f64),
    I(i64),
    V(Value),
}

fn to_value(ty: ParamType, n: Num) -> Value {
    let int = |n: &Num| match *n {
        Num::F(x) => x.round() as i64,
        Num::I(i) => i,
        Num::V(v) => v.as_f64().map_or(0, |x| x as i64),
    };
    match (ty, n) {
        (_, Num::V(v)) => v,
        (ParamType::Float, Num::F(x)) => Value::Float(x as f32),
        (ParamType::Float, Num::I(i)) => Value::Float(i as f32),
        (ParamType::Int32, n) => Value::Int32(int(&n).clamp(i32::MIN.into(), i32::MAX.into()) as i32),
        // Tick values are signed on the module even where the manual says
        // UInt32 (specs README): negative ones go out as two's complement.
        (ParamType::UInt32, n) => {
            let i = int(&n);
            Value::UInt32(if i < 0 { i.max(i32::MIN.into()) as i32 as u32 } else { i.min(u32::MAX.into()) as u32 })
        }
        (ParamType::Int16, n) => Value::Int16(int(&n).clamp(i16::MIN.into(), i16::MAX.into()) as i16),
        (ParamType::UInt16, n) => Value::UInt16(int(&n).clamp(0, u16::MAX.into()) as u16),
        (ParamType::UInt8, n) => Value::UInt8(int(&n).clamp(0, u8::MAX.into()) as u8),
        (ParamType::FloatStateDio, n) => Value::FloatStateDio { position: int(&n) as f32, short_state: 0, dio: 0 },
        (ParamType::FloatTime, n) => Value::FloatTime { position: int(&n) as f32, time_ms: 0 },
    }
}

impl Module {
    /// What GetExtended of `param` answers, as of the last `advance`: the
    /// value in the type `table::PARAMS` gives. Parameters the table marks
    /// write-only (TargetPos, TargetVel, TargetAcc) or neither (DefA0) are
    /// answered too, with their current value. `None` for ids not in the
    /// table: the module does not answer those.
    pub fn get(&self, param: u8) -> Option<Value> {
        let def = table::param(param).filter(|_| table::firmware_has(self.spec.version, param))?;
        let d = &self.def;
        let k = self.kin();
        let inc = self.inc_ratio();
        let ticks = |x: f64| Num::I(self.to_ticks(x));
        let n = match param {
            ids::DEF_HOME_OFFSET => Num::F(d.home_offset),
            ids::DEF_GEAR_RATIO => Num::F(d.gear_ratio),
            ids::DEF_LIN_RATIO => Num::F(d.lin_ratio),
            ids::DEF_MIN_POS => Num::F(d.min_pos),
            ids::DEF_MAX_POS => Num::F(d.max_pos),
            ids::DEF_MAX_DELTA_POS => Num::F(d.max_delta_pos),
            ids::DEF_MAX_DELTA_VEL => Num::F(d.max_delta_vel),
            ids::DEF_TORQUE_RATIO => Num::F(d.torque_ratio),
            ids::DEF_CUR_RATIO => Num::F(d.cur_ratio),
            ids::DEF_MIN_VEL => Num::F(d.min_vel),
            ids::DEF_MAX_VEL => Num::F(d.max_vel),
            ids::DEF_MIN_ACC => Num::F(d.min_acc),
            ids::DEF_MAX_ACC => Num::F(d.max_acc),
            ids::DEF_MIN_CUR => Num::F(d.min_cur),
            ids::DEF_MAX_CUR => Num::F(d.max_cur),
            ids::DEF_HOME_VEL => Num::F(d.home_vel),
            ids::DEF_HOME_ACC => Num::F(d.home_acc),
            ids::DEF_CUBE_SERIAL => Num::I(d.serial.into()),
            ids::DEF_CONFIG => Num::I(d.config.into()),
            ids::DEF_PULSES_PER_TURN => Num::I(d.pulses_per_turn.into()),
            ids::DEF_CUBE_VERSION => Num::I(d.version.into()),
            ids::DEF_SERVICE_INTERVAL => Num::I(d.service_interval.into()),
            ids::DEF_BRAKE_TIME_OUT => Num::I(d.brake_timeout_ms.into()),
            ids::DEF_ADDRESS => Num::I(d.address.into()),
            ids::DEF_PRIM_BAUD => Num::I(d.prim_baud.into()),
            ids::DEF_SCND_BAUD => Num::I(d.scnd_baud.into()),
            ids::POS_COUNT => Num::I(self.pos_count()),
            ids::REF_POS_COUNT => Num::I(self.ref_pos_count),
            ids::DIO_SETUP => {
                let swr = if self.home_switch_active(k.pos) { dio_setup::INSWR } else { 0 };
                Num::I((u32::from(self.inputs & 0x0f) | u32::from(self.outputs & 0x0f) << 4 | swr).into())
            }
            ids::CUBE_STATE => Num::I(self.cube_state().into()),
            ids::TARGET_POS_INC => ticks(self.target.pos),
            ids::TARGET_VEL_INC => ticks(self.target.vel),
            ids::TARGET_ACC_INC => ticks(self.target.acc),
            ids::STEP_INC => ticks(self.step_target),
            ids::HOME_OFFSET_INC => ticks(self.home_offset),
            ids::RAW_CUR => Num::F(self.motor_current() / d.cur_ratio),
            ids::HOME_TO_ZERO_INC => Num::I(d.home_to_zero_inc.into()),
            ids::CONFIG => Num::I(self.config.into()),
            ids::MOVE_MODE => Num::I(self.move_mode.into()),
            ids::INC_RATIO => Num::F(inc),
            ids::ACT_POS | ids::I_POL_POS => Num::F(k.pos),
            ids::ACT_POS_PREV => Num::F(k.pos - k.vel * SERVO_CYCLE_S),
            // The simulated servo follows its set point exactly.
            ids::DELTA_POS => Num::F(0.0),
            ids::ACT_I_DELTA_POS => Num::I(0),
            ids::MAX_DELTA_POS => Num::F(self.lim.max_delta_pos),
            ids::ACT_VEL | ids::I_POL_VEL => Num::F(k.vel),
            ids::MIN_POS => Num::F(self.lim.min_pos),
            ids::MAX_POS => Num::F(self.lim.max_pos),
            ids::MAX_VEL => Num::F(self.lim.max_vel),
            ids::MAX_ACC => Num::F(self.lim.max_acc),
            ids::MAX_CUR => Num::F(self.lim.max_cur),
            ids::CUR => Num::F(self.motor_current()),
            ids::TARGET_POS => Num::F(self.target.pos),
            ids::TARGET_VEL => Num::F(self.target.vel),
            ids::TARGET_ACC => Num::F(self.target.acc),
            ids::DEF_C0 => Num::I(d.c0.into()),
            ids::DEF_DAMP => Num::I(d.damp.into()),
            ids::DEF_A0 => Num::I(d.a0.into()),
            ids::ACT_C0 => Num::I(self.c0.into()),
            ids::ACT_DAMP => Num::I(self.damp.into()),
            ids::ACT_A0 => Num::I(self.a0.into()),
            ids::DEF_BURN_COUNT => Num::I(d.burn_count.into()),
            ids::SETUP => {
                let iface = match self.iface {
                    super::module::Iface::Can => setup::CAN,
                    super::module::Iface::Rs232 => setup::RS232,
                };
                Num::I((d.setup | iface).into())
            }
            ids::HOME_OFFSET => Num::F(self.home_offset),
            ids::ACT_I_POS => Num::I(self.act_ipos().into()),
            ids::ACT_I_MAX_DELTA_POS => ticks(self.lim.max_delta_pos),
            ids::ACT_I_MIN_POS => ticks(self.lim.min_pos),
            ids::ACT_I_MAX_POS => ticks(self.lim.max_pos),
            ids::ACT_I_MAX_VEL => ticks(self.lim.max_vel),
            ids::ACT_I_MAX_ACC => ticks(self.lim.max_acc),
            ids::ACT_I_VEL | ids::ACT_II_POL_VEL => ticks(k.vel),
            ids::ACT_F_POS_STATE_DIO => Num::V(Value::FloatStateDio {
                position: k.pos as f32,
                short_state: self.short_state(),
                dio: self.dio(),
            }),
            ids::ACT_F_SAVED_POS => Num::F(self.saved_pos),
            ids::ACT_F_HOME_VEL => Num::F(d.home_vel),
            ids::ACT_I_HOME_VEL => ticks(d.home_vel),
            ids::ACT_SYNC_TIME => Num::I(self.sync_time.into()),
            ids::ACT_RAW_MOTOR_CURRENT => Num::F(self.bus_current() / AMP_PER_DIGIT),
            ids::ACT_RAW_MOTOR_SUPPLY => Num::F(MOTOR_SUPPLY_V / VOLT_PER_DIGIT),
            ids::ACT_RAW_TEMP => Num::F(TEMPERATURE_C / DEGC_PER_DIGIT),
            ids::ACT_RAW_LOGIC_SUPPLY => Num::F(LOGIC_SUPPLY_V / VOLT_PER_DIGIT),
            ids::ACT_F_MOTOR_CURRENT => Num::F(self.bus_current()),
            ids::ACT_F_MOTOR_SUPPLY => Num::F(MOTOR_SUPPLY_V),
            ids::ACT_F_TEMP => Num::F(TEMPERATURE_C),
            ids::ACT_F_LOGIC_SUPPLY => Num::F(LOGIC_SUPPLY_V),
            ids::ACT_MIN_LOGIC_SUPPLY => Num::F(self.sup.logic_min),
            ids::ACT_MAX_LOGIC_SUPPLY => Num::F(self.sup.logic_max),
            ids::ACT_MIN_MOTOR_SUPPLY => Num::F(self.sup.motor_min),
            ids::ACT_MAX_MOTOR_SUPPLY => Num::F(self.sup.motor_max),
            ids::ACT_LOGIC_UNDERSHOOT_TIME => Num::I(self.sup.logic_under_ms.into()),
            ids::ACT_LOGIC_OVERSHOOT_TIME => Num::I(self.sup.logic_over_ms.into()),
            ids::ACT_MOTOR_UNDERSHOOT_TIME => Num::I(self.sup.motor_under_ms.into()),
            ids::ACT_MOTOR_OVERSHOOT_TIME => Num::I(self.sup.motor_over_ms.into()),
            ids::ACT_MAX_TEMP => Num::F(self.sup.temp_max),
            ids::ACT_MIN_TEMP => Num::F(self.sup.temp_min),
            ids::ACT_F_POS_TIME => {
                // A free-running millisecond counter, wrapping at 16 bits.
                let ms = ((self.t - self.time_zero).max(0.0) * 1000.0) as u64;
                Num::V(Value::FloatTime { position: k.pos as f32, time_ms: (ms & 0xffff) as u16 })
            }
            // No encoder signal on SW3 in the simulation: nothing latched.
            ids::ACT_F_SCAN_POS_FALL_EDGE | ids::ACT_F_SCAN_POS_RISG_EDGE => Num::F(0.0),
            _ => return None,
        };
        Some(to_value(def.ty, n))
    }

    fn bus_current(&self) -> f64 {
        IDLE_BUS_CURRENT_A + 0.5 * self.motor_current().abs()
    }

    /// SetExtended: `false` if the parameter is unknown or read-only (no
    /// acknowledge). Data that does not decode as the parameter's type is
    /// acknowledged but changes nothing. Values are
    /// limited as manual 12 says: limits to the ROM range, targets to the
    /// limits. Non-finite floats are ignored.
    pub(super) fn set_extended(&mut self, param: u8, data: &[u8]) -> bool {
        let Some(def) = table::param(param) else { return false };
        if !def.access.writable() {
            return false;
        }
        let Ok(value) = Value::decode(def.ty, data) else { return true };
        let Some(x) = value.as_f64().filter(|x| x.is_finite()) else { return true };
        self.set_number(param, value, x);
        true
    }

    fn set_number(&mut self, param: u8, value: Value, x: f64) {
        let inc = self.inc_ratio();
        let d = self.def.clone();
        // Tick parameters are signed on the module (specs README).
        let signed = match value {
            Value::UInt32(u) => f64::from(u as i32),
            _ => x,
        };
        match param {
            ids::DIO_SETUP => self.outputs = ((x as u32) >> 4) as u8 & 0x0f,
            ids::TARGET_POS_INC => self.target.pos = self.clamp_pos(signed / inc),
            ids::TARGET_VEL_INC => self.target.vel = self.limit_target_vel(signed / inc),
            ids::TARGET_ACC_INC => self.target.acc = self.limit_target_acc(signed / inc),
            ids::RAW_CUR => self.cmd_cur = limit(x, -500.0, 500.0) * d.cur_ratio,
            ids::CUR => self.cmd_cur = limit(x, -self.lim.max_cur, self.lim.max_cur),
            ids::CONFIG => self.set_config(x as u32),
            ids::MAX_DELTA_POS => self.lim.max_delta_pos = limit(x, 0.0, d.max_delta_pos),
            ids::MIN_POS => self.lim.min_pos = limit(x, d.min_pos, self.lim.max_pos),
            ids::MAX_POS => self.lim.max_pos = limit(x, self.lim.min_pos, d.max_pos),
            ids::MAX_VEL => self.lim.max_vel = limit(x, d.min_vel, d.max_vel),
            ids::MAX_ACC => self.lim.max_acc = limit(x, d.min_acc, d.max_acc),
            ids::MAX_CUR => self.lim.max_cur = limit(x, 0.0, d.max_cur),
            ids::TARGET_POS => self.target.pos = self.clamp_pos(x),
            ids::TARGET_VEL => self.target.vel = self.limit_target_vel(x),
            ids::TARGET_ACC => self.target.acc = self.limit_target_acc(x),
            ids::ACT_C0 => self.c0 = x as i16,
            ids::ACT_DAMP => self.damp = x as i16,
            ids::ACT_A0 => self.a0 = x as i16,
            // Takes effect at the next homing.
            ids::HOME_OFFSET => self.home_offset = x,
            ids::ACT_I_MAX_DELTA_POS => self.set_number(ids::MAX_DELTA_POS, Value::Float(0.0), signed / inc),
            ids::ACT_I_MIN_POS => self.set_number(ids::MIN_POS, Value::Float(0.0), signed / inc),
            ids::ACT_I_MAX_POS => self.set_number(ids::MAX_POS, Value::Float(0.0), signed / inc),
            ids::ACT_I_MAX_VEL => self.set_number(ids::MAX_VEL, Value::Float(0.0), signed / inc),
            ids::ACT_I_MAX_ACC => self.set_number(ids::MAX_ACC, Value::Float(0.0), signed / inc),
            ids::ACT_SYNC_TIME => self.sync_time = x as u16,
            ids::ACT_MIN_LOGIC_SUPPLY => self.sup.logic_min = x,
            ids::ACT_MAX_LOGIC_SUPPLY => self.sup.logic_max = x,
            ids::ACT_MIN_MOTOR_SUPPLY => self.sup.motor_min = x,
            ids::ACT_MAX_MOTOR_SUPPLY => self.sup.motor_max = x,
            ids::ACT_LOGIC_UNDERSHOOT_TIME => self.sup.logic_under_ms = x as u32,
            ids::ACT_LOGIC_OVERSHOOT_TIME => self.sup.logic_over_ms = x as u32,
            ids::ACT_MOTOR_UNDERSHOOT_TIME => self.sup.motor_under_ms = x as u32,
            ids::ACT_MOTOR_OVERSHOOT_TIME => self.sup.motor_over_ms = x as u32,
            ids::ACT_MAX_TEMP => self.sup.temp_max = x,
            ids::ACT_MIN_TEMP => self.sup.temp_min = x,
            _ => {}
        }
    }

    fn limit_target_vel(&self, v: f64) -> f64 {
        limit(v.abs(), self.def.min_vel, self.lim.max_vel)
    }

    fn limit_target_acc(&self, a: f64) -> f64 {
        limit(a.abs(), self.def.min_acc, self.lim.max_acc)
    }

    /// The type bits (LINEAR, LINEAR_SCREW) are hardware: writes keep them.
    fn set_config(&mut self, word: u32) {
        let hw = config::LINEAR | config::LINEAR_SCREW;
        self.config = (word & !hw) | (self.def.config & hw);
        if self.config & config::WATCHDOG_ENABLE == 0 {
            self.wd_online = false;
        }
    }
}
