//! The ROM ("Def*") values of a simulated module, per kind, and the few
//! physical constants of the simulated bench. Units: rad for rotary modules,
//! m for linear ones.

use super::ModuleKind;
use crate::proto::powercube::flags::{config, setup};

/// Firmware version the bench's modules report (4.6.01): the first that has
/// the temperature and supply voltages the simulation answers.
pub const DEFAULT_VERSION: u16 = 0x4601;

/// The older firmware module 17 keeps (3.5.18, as `scan` shows in
/// cli-contract.md: 13592): it does not answer the 4.6 measurements.
pub const LEGACY_VERSION: u16 = 0x3518;

/// The module of the contract's bench that keeps [`LEGACY_VERSION`].
pub const LEGACY_MODULE: u8 = 17;

/// The ROM values, one field per `Def*` parameter plus what the simulation
/// needs about the bench (home switch distance, servo cycle, scales).
#[derive(Debug, Clone, PartialEq)]
pub struct Defaults {
    pub home_offset: f64,
    pub gear_ratio: f64,
    pub lin_ratio: f64,
    pub min_pos: f64,
    pub max_pos: f64,
    pub max_delta_pos: f64,
    pub max_delta_vel: f64,
    pub torque_ratio: f64,
    /// Ampere per current digit (RawCur, ICUR_MODE).
    pub cur_ratio: f64,
    pub min_vel: f64,
    pub max_vel: f64,
    pub min_acc: f64,
    pub max_acc: f64,
    pub min_cur: f64,
    pub max_cur: f64,
    /// Signed: the sign is the homing direction.
    pub home_vel: f64,
    pub home_acc: f64,
    pub serial: u32,
    pub config: u32,
    pub pulses_per_turn: u32,
    pub version: u16,
    pub service_interval: u16,
    pub brake_timeout_ms: u16,
    pub address: u8,
    pub prim_baud: u8,
    pub scnd_baud: u8,
    pub c0: i16,
    pub damp: i16,
    pub a0: i16,
    pub burn_count: u8,
    /// Setup word without the interface bit (CAN or RS232 is added by the
    /// interface the module is talking on).
    pub setup: u32,
    /// Encoder ticks between the home switch edge and the encoder index.
    pub home_to_zero_inc: i32,
    /// Distance from the power-on position to the home switch edge, in the
    /// homing direction.
    pub home_distance: f64,
    /// The home switch is active over this length past its edge.
    pub switch_width: f64,
    /// Time spent creeping onto the switch edge at the end of homing, s.
    pub home_settle: f64,
}

impl Defaults {
    pub fn new(kind: ModuleKind, serial: u32, version: u16, address: u8) -> Self {
        let common = |config_bits: u32| Self {
            home_offset: 0.0,
            gear_ratio: 0.0,
            lin_ratio: 0.0,
            min_pos: 0.0,
            max_pos: 0.0,
            max_delta_pos: 0.0,
            max_delta_vel: 0.0,
            torque_ratio: 0.0,
            cur_ratio: 0.01,
            min_vel: 0.0,
            max_vel: 0.0,
            min_acc: 0.0,
            max_acc: 0.0,
            min_cur: -5.0,
            max_cur: 5.0,
            home_vel: 0.0,
            home_acc: 0.0,
            serial,
            config: config::SWR_ENABLED | config::SW1_ENABLED | config::SW2_ENABLED | config_bits,
            pulses_per_turn: 2000,
            version,
            service_interval: 5000,
            brake_timeout_ms: 100,
            address,
            // 3 = 1 Mbit/s (the broadcast baud rate codes of manual 4.1.2);
            // the secondary (RS232) setting 0 = 9600 baud.
            prim_baud: 3,
            scnd_baud: 0,
            c0: 24,
            damp: 3,
            a0: 1,
            burn_count: 2,
            setup: setup::MOD_4IN_4OUT,
            home_to_zero_inc: 500,
            home_distance: 0.0,
            switch_width: 0.0,
            home_settle: 0.2,
        };
        match kind {
            ModuleKind::Rotary => Self {
                gear_ratio: 101.0,
                min_pos: -3.1,
                max_pos: 3.1,
                max_delta_pos: 0.05,
                max_delta_vel: 0.5,
                torque_ratio: 2.2,
                min_vel: 0.001,
                max_vel: 1.5,
                min_acc: 0.001,
                max_acc: 3.0,
                home_vel: -0.2,
                home_acc: 1.0,
                home_distance: 0.3,
                switch_width: 0.05,
                ..common(0)
            },
            ModuleKind::Linear => Self {
                gear_ratio: 5.0,
                // m of travel per output revolution (ball screw lead).
                lin_ratio: 0.01,
                min_pos: 0.0,
                // Long enough for the manual's examples (ramp to 0.75).
                max_pos: 1.0,
                max_delta_pos: 0.005,
                max_delta_vel: 0.05,
                torque_ratio: 60.0,
                min_vel: 0.0001,
                max_vel: 0.1,
                min_acc: 0.0001,
                max_acc: 0.5,
                home_vel: -0.02,
                home_acc: 0.1,
                home_distance: 0.03,
                switch_width: 0.005,
                ..common(config::LINEAR | config::LINEAR_SCREW)
            },
        }
    }

    /// Encoder ticks per rad or per m.
    pub fn inc_ratio(&self) -> f64 {
        let per_output_turn = f64::from(self.pulses_per_turn) * self.gear_ratio;
        if self.lin_ratio > 0.0 {
            per_output_turn / self.lin_ratio
        } else {
            per_output_turn / std::f64::consts::TAU
        }
    }

    /// The nominal current: what a current command may ask for unless
    /// CONFIGID_MOD_ALLOW_FULL_CUR is set.
    pub fn nominal_cur(&self) -> f64 {
        self.max_cur / 2.0
    }
}
