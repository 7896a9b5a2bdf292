//! What users type: PowerCube values, flag words and parameter names; the
//! PA-CONTROL command builder and validator; the Cdios field encoder.
//! Invariants: no panic; accepted values print back to text that parses to
//! the same value; whatever the validators accept encodes and decodes to the
//! same command and passes validation again.
#![no_main]

use axisctl::proto::cdios::{self, table as cdios_table, Address};
use axisctl::proto::pac::table as pac_table;
use axisctl::proto::pac::validate::{self, Context};
use axisctl::proto::pac::{Command as PacCommand, Par2};
use axisctl::proto::powercube::flags;
use axisctl::proto::powercube::frame::{parse_int, Value};
use axisctl::proto::powercube::table::{self as pc_table, ParamType};
use libfuzzer_sys::fuzz_target;

#[path = "common.rs"]
mod common;

const TYPES: [ParamType; 8] = [
    ParamType::Float,
    ParamType::Int32,
    ParamType::UInt32,
    ParamType::Int16,
    ParamType::UInt16,
    ParamType::UInt8,
    ParamType::FloatStateDio,
    ParamType::FloatTime,
];

fn powercube(text: &str) {
    let _ = parse_int(text);
    for ty in TYPES {
        if let Ok(v) = Value::parse(ty, text) {
            assert_eq!(v.ty(), ty);
            let printed = v.to_string();
            assert_eq!(Value::parse(ty, &printed), Ok(v), "{text:?} printed as {printed:?}");
            assert_eq!(Value::decode(ty, v.to_payload().as_slice()), Ok(v));
        }
    }
    for word in flags::WORDS {
        if let Ok(raw) = word.parse(text) {
            assert_eq!(raw & !word.width_mask(), 0, "{text:?} parsed beyond the {} bits of {}", word.bits, word.name);
            let d = word.decode(raw);
            assert_eq!(word.parse(&d.flags.join("|")), Ok(raw & word.known_mask()));
            assert_eq!(word.parse(&format!("{raw:#x}")), Ok(raw));
            let _ = d.to_string();
        }
        let _ = word.flag(text);
    }
    if let Some(def) = pc_table::resolve_param(text) {
        assert!(std::ptr::eq(pc_table::param(def.id).expect("by id"), def));
        assert!(std::ptr::eq(pc_table::resolve_param(&format!("{:#x}", def.id)).expect("by hex id"), def));
        assert!(std::ptr::eq(pc_table::resolve_param(def.name).expect("by name"), def));
    }
    if let Some(m) = pc_table::motion_by_name(text) {
        assert!(std::ptr::eq(pc_table::motion(m.id).expect("by id"), m));
    }
    let _ = flags::word(text);
}

fn pa_control(b: &mut common::Bytes) {
    let def = &pac_table::COMMANDS[usize::from(b.u8()) % pac_table::COMMANDS.len()];
    let par1 = if b.bool() { i64::from(b.u16() as i16) } else { b.u64() as i64 };
    let value = match b.u8() % 4 {
        0 => None,
        1 => Some(f64::from(b.u16() as i16)),
        2 => Some(f64::from(b.u32() as i32) / 1000.0),
        _ => Some(f64::from_bits(b.u64())),
    };
    let mut ctx = Context { axes: b.u8(), status: b.bool().then(|| b.u16() % 64), ..Context::default() };
    if b.bool() {
        let (lo, hi) = (f64::from(b.u16() as i16), f64::from(b.u16() as i16));
        ctx.axis_param_limits.insert(par1, (lo, hi));
        ctx.system_param_limits.insert(par1, (lo as i64, hi as i64));
    }
    if let Ok(cmd) = validate::build(def, par1, value, &ctx) {
        assert_eq!(cmd.code, def.code);
        assert_eq!(validate::validate_in(&cmd, &ctx).map(|d| d.code), Ok(def.code));
        let bytes = cmd.encode().expect("a validated command is finite");
        let (again, _) = PacCommand::decode(&bytes).expect("a validated command decodes");
        assert_eq!(again, cmd);
        assert_eq!(validate::validate_in(&again, &ctx).map(|d| d.code), Ok(def.code));
    }
    // Any command at all, as a decoded frame would carry it.
    let code = if b.bool() { def.code } else { b.u16() };
    let par2 = if b.bool() { Par2::Float(f64::from_bits(b.u64())) } else { Par2::Int(b.u64() as i64) };
    let cmd = PacCommand::new(code, par1, par2);
    let _ = validate::validate(&cmd);
    let _ = validate::validate_in(&cmd, &ctx);
    let cond = b.u64() as i64;
    if let Some(c) = pac_table::Condition::decode(cond) {
        assert_eq!(c.encode(), cond);
    }
    let _ = pac_table::split_axis_param_par1(par1);
    let text = String::from_utf8_lossy(b.rest());
    let _ = pac_table::command_by_name(&text);
    let _ = pac_table::system_param_by_name(&text);
    let _ = pac_table::axis_param_by_name(&text);
}

fn cdios_fields(b: &mut common::Bytes) {
    let def = &cdios_table::COMMANDS[usize::from(b.u8()) % cdios_table::COMMANDS.len()];
    let address = match b.u8() {
        a @ 0..=15 => Address::Module(cdios::ModuleId::new(a).expect("0..=15")),
        _ => Address::Controller,
    };
    let selector = match b.u8() {
        s if s & 0x80 != 0 => b.u8(),
        s => {
            let sd = &def.selectors[usize::from(s) % def.selectors.len()];
            sd.lo.saturating_add(b.u8() % (sd.hi - sd.lo).saturating_add(1))
        }
    };
    let mut values = Vec::new();
    for f in def.value_fields() {
        let v = match b.u8() % 8 {
            0 => continue,
            1 => b.u64() as i64,
            2 => f.min.saturating_sub(1),
            3 => f.max.saturating_add(1),
            _ => {
                let span = (f.max as i128 - f.min as i128 + 1) as u128;
                (f.min as i128 + (u128::from(b.u64()) % span) as i128) as i64
            }
        };
        values.push((f.key, v));
    }
    if b.u8() == 0xA5 {
        values.push(("no_such_field", 0));
    }
    if let Ok(bytes) = cdios_table::encode(def, address, selector, &values) {
        let d = cdios_table::decode_command(&bytes).expect("an encoded command decodes");
        assert_eq!((d.def.key, d.address, d.selector), (def.key, address, selector));
        assert_eq!(d.validate(), Ok(()));
        for (k, v) in &values {
            assert_eq!(d.get(k), Some(*v), "{}: field {k}", def.key);
        }
        match cdios::Command::decode(&bytes) {
            Ok((a, cmd)) => {
                assert_eq!(a, address);
                assert_eq!(cmd.encode(a), Ok(bytes), "{}", def.key);
            }
            Err(e) => panic!("{} {bytes:02x?} passes the table but not the typed decoder: {e}", def.key),
        }
    }
    let _ = cdios_table::command(&String::from_utf8_lossy(b.rest()));
}

fuzz_target!(|data: &[u8]| {
    let Some((&which, rest)) = data.split_first() else { return };
    match which % 3 {
        0 => powercube(&String::from_utf8_lossy(rest)),
        1 => pa_control(&mut common::Bytes(rest)),
        _ => cdios_fields(&mut common::Bytes(rest)),
    }
});
