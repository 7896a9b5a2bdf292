//! CubeState, short state, DIO, Setup, Config and Profibus words.
//!
//! Every flag of every word is one [`FlagDef`] row; a [`FlagWord`] groups the
//! rows of one word and decodes raw values. [`WORDS`] lists them by the
//! `kind` key `axisctl decode KIND VALUE` takes. The per-word `mod`s hold the
//! masks other code names directly; the rows read them, so each mask is
//! written once.

use super::frame::{Payload, Response};
use super::table::{self, CommandId};
use crate::proto::DecodeError;

pub use crate::proto::flag_word::{Decoded, FlagClass, FlagDef, FlagParseError, FlagWord};

const fn f(
    name: &'static str,
    mask: u32,
    class: FlagClass,
    short: Option<&'static str>,
    description: &'static str,
) -> FlagDef {
    FlagDef { name, mask, class, short, description }
}

use FlagClass::{Error, Info, Obsolete, Warning};

/// CubeState masks (manual 5, with the specs README errata).
pub mod state {
    /// `STATE_ERROR`
    pub const ERROR: u32 = 0x00000001;
    /// `STATE_HOME_OK`
    pub const HOME_OK: u32 = 0x00000002;
    /// `STATE_HALTED`
    pub const HALTED: u32 = 0x00000004;
    /// `STATE_POWERFAULT`
    pub const POWERFAULT: u32 = 0x00000008;
    /// `STATE_TOW_ERROR`
    pub const TOW_ERROR: u32 = 0x00000010;
    /// `STATE_COMM_ERROR`
    pub const COMM_ERROR: u32 = 0x00000020;
    /// `STATE_SWR`
    pub const SWR: u32 = 0x00000040;
    /// `STATE_SW1`
    pub const SW1: u32 = 0x00000080;
    /// `STATE_SW2`
    pub const SW2: u32 = 0x00000100;
    /// `STATE_BRAKEACTIVE`
    pub const BRAKEACTIVE: u32 = 0x00000200;
    /// `STATE_CURLIMIT`
    pub const CURLIMIT: u32 = 0x00000400;
    /// `STATE_MOTION`
    pub const MOTION: u32 = 0x00000800;
    /// `STATE_RAMP_ACC`
    pub const RAMP_ACC: u32 = 0x00001000;
    /// `STATE_RAMP_STEADY`
    pub const RAMP_STEADY: u32 = 0x00002000;
    /// `STATE_RAMP_DEC`
    pub const RAMP_DEC: u32 = 0x00004000;
    /// `STATE_RAMP_END`
    pub const RAMP_END: u32 = 0x00008000;
    /// `STATE_INPROGRESS`
    pub const INPROGRESS: u32 = 0x00010000;
    /// `STATE_FULLBUFFER`
    pub const FULLBUFFER: u32 = 0x00020000;
    /// `STATE_POW_VOLT_ERR`
    pub const POW_VOLT_ERR: u32 = 0x00040000;
    /// `STATE_POW_FET_TEMP`
    pub const POW_FET_TEMP: u32 = 0x00080000;
    /// `STATE_POW_WDG_TEMP`
    pub const POW_WDG_TEMP: u32 = 0x00100000;
    /// `STATE_POW_SHORTCUR`
    pub const POW_SHORTCUR: u32 = 0x00200000;
    /// `STATE_POW_HALLERR`
    pub const POW_HALLERR: u32 = 0x00400000;
    /// `STATE_POW_INTEGRAL_ERR`
    pub const POW_INTEGRAL_ERR: u32 = 0x00800000;
    /// `STATE_CPU_OVERLOAD`
    pub const CPU_OVERLOAD: u32 = 0x01000000;
    /// `STATE_BEYOND_HARD`
    pub const BEYOND_HARD: u32 = 0x02000000;
    /// `STATE_BEYOND_SOFT`
    pub const BEYOND_SOFT: u32 = 0x04000000;
    /// `STATE_LOGIC_VOLT`
    pub const LOGIC_VOLT: u32 = 0x08000000;
    /// `STATE_POW_SETUP_ERR`
    pub const POW_SETUP_ERR: u32 = 0x08000000;
}

// Manual 5. STATE_POW_INTEGRAL_ERR is bit 23 (the manual prints bit 19's
// value); bit 27 carries STATE_LOGIC_VOLT or, on firmware 3.5.14..3.5.1D,
// STATE_POW_SETUP_ERR, so both rows share it and a decode shows both names.
// The manual's third legend entry, "[These flags are obsolete]", marks rows by
// colour, which the text does not keep; no CubeState row is classed obsolete.
// STATE_HALTED is info: the manual calls it a state, not an error.
const CUBE_STATE_FLAGS: &[FlagDef] = &[
    f("STATE_ERROR", state::ERROR, Error, Some("error"), "An error occurred. The module stop immediately and does not accept motion commands anymore. The reason for the error state can be found reading the error flags. In many cases the error state can be reset by the user sending a Reset command. After a successful Reset the module is ready again to accept motion commands."),
    f("STATE_HOME_OK", state::HOME_OK, Info, Some("home-ok"), "This flag is set after a successful homing procedure. It means that the drive has successfully found its zero position. All limitations for the operation range are valid now. If the user sends another Home-Command the flag will be reset until the homing procedure has been finished successfully."),
    f("STATE_HALTED", state::HALTED, Info, Some("halted"), "This flag is set in conjunction with an emergency stop. It means that the cube is in a secure state, not moving and not accepting motion commands. Only after a reset command which resets this flag, the module will return to the normal operation mode. An emergency stop can be caused automatically by the module in case of an error or by the user when sending a Halt command."),
    f("STATE_POWERFAULT", state::POWERFAULT, Error, Some("powerfault"), "This flag defines an error of the servo amplifier. This flag is set in conjunction with STATE_ERROR. In most cases the module needs to be switched off to reset this error. One of the flags 18 through 23 will be set to explain the cause."),
    f("STATE_TOW_ERROR", state::TOW_ERROR, Error, Some("tow-error"), "Tow error: The servo loop was not able to follow the target position within the given limit. The maximum tow can be adjusted using the parameter \"MaxDeltaPos\". Check if the module was overloaded."),
    f("STATE_COMM_ERROR", state::COMM_ERROR, Error, Some("comm-error"), "This error flag is raised if the watchdog has been enabled only. When enabled the watchdog must be refreshed in a given period of time by the external control. If the external control fails to do so, the drive will follow the emergency Stop routine and enter an error state."),
    f("STATE_SWR", state::SWR, Info, Some("swr"), "This flag shows the state of the home switch. Flag set means home switch is active. This is no error flag."),
    f("STATE_SW1", state::SW1, Info, Some("sw1"), "This flag shows the state of the Limit switch 1. Flag set means limit switch 1 is active. This is no error flag."),
    f("STATE_SW2", state::SW2, Info, Some("sw2"), "This flag shows the state of the Limit switch 2. Flag set means limit switch 2 is active. This is no error flag."),
    f("STATE_BRAKEACTIVE", state::BRAKEACTIVE, Info, Some("brakeactive"), "This flag shows the state of the brake. Flag set means brake is active and servo loop is open. This is no error flag and it is used only if a brake is installed."),
    f("STATE_CURLIMIT", state::CURLIMIT, Warning, Some("curlimit"), "This flag is a warning of the servo loop. It has reached the maximum current output. The drive is working at its limits. This flag can be reset by the Reset command. It is no error flag"),
    f("STATE_MOTION", state::MOTION, Info, Some("motion"), "This flag indicates the drive is in motion. It is set and reset automatically."),
    f("STATE_RAMP_ACC", state::RAMP_ACC, Info, Some("ramp-acc"), "This flag indicates the drive is in acceleration when controlled by ramp motion commands. It is automatically reset when the ramp motion profile has ended."),
    f("STATE_RAMP_STEADY", state::RAMP_STEADY, Info, Some("ramp-steady"), "This flag indicates the drive is moving at constant speed when controlled by ramp motion commands. It is automatically reset when the ramp motion profile has ended."),
    f("STATE_RAMP_DEC", state::RAMP_DEC, Info, Some("ramp-dec"), "This flag indicates the drive is in deceleration when controlled by ramp motion commands. It is automatically reset when the ramp motion profile has ended."),
    f("STATE_RAMP_END", state::RAMP_END, Info, Some("ramp-end"), "This flag indicates the end of a ramp motion profile. The drive is not moving."),
    f("STATE_INPROGRESS", state::INPROGRESS, Info, Some("inprogress"), "This flag is only used in Step motion control. It indicates a Step motion command is in progress."),
    f("STATE_FULLBUFFER", state::FULLBUFFER, Info, Some("fullbuffer"), "This flag is only used in Step motion control. It indicates a Step motion command was pushed to the command stack. This happens when the module receives a Step motion command while STATE_INPROGRESS is set. Upon completion of the currently executed step command, the buffered one will automatically be executed."),
    f("STATE_POW_VOLT_ERR", state::POW_VOLT_ERR, Error, Some("pow-volt-err"), "This flag is set in conjunction with STATE_POWERFAULT. It indicates a voltage drop or an overvoltage occurred in the motor supply. This error can be reset after the normal voltage level has been restored. Check your power supply."),
    f("STATE_POW_FET_TEMP", state::POW_FET_TEMP, Error, Some("pow-fet-temp"), "This flag is set in conjunction with STATE_POWERFAULT. The power transistors have overheated and the servo loop has been disabled. Power must be switched off to reset this error. It is due to overload or too high ambient temperature."),
    f("STATE_POW_WDG_TEMP", state::POW_WDG_TEMP, Error, Some("pow-wdg-temp"), "This flag is set in conjunction with STATE_POWERFAULT. The motor has overheated and the servo loop has been disabled. Power must be switched off to reset this error. It is due to overload or too high ambient temperature."),
    f("STATE_POW_SHORTCUR", state::POW_SHORTCUR, Error, Some("pow-shortcur"), "This flag is set in conjunction with STATE_POWERFAULT. A short circuit occurred. The servo loop has been disabled. The power must be switched off to reset this error. The module has been overloaded. If this error cannot be reset consult your service partner."),
    f("STATE_POW_HALLERR", state::POW_HALLERR, Error, Some("pow-hallerr"), "This flag is set in conjunction with STATE_POWERFAULT. An error occurred in reading the hall effect sensors of the motor. The motor has been overheated. Power must be switched off to reset this error."),
    f("STATE_POW_INTEGRAL_ERR", state::POW_INTEGRAL_ERR, Error, Some("pow-integral-err"), "This flag is set in conjunction with STATE_POWERFAULT. The drive has been overloaded and the servo loop has been disabled. Power must be switched off to reset this error. Check your application and the load situations of the drive."),
    f("STATE_CPU_OVERLOAD", state::CPU_OVERLOAD, Error, Some("cpu-overload"), "Communication breakdown between CPU and current controller. Power must be switched off. Please consult your service partner."),
    f("STATE_BEYOND_HARD", state::BEYOND_HARD, Error, Some("beyond-hard"), "This flag indicates the module has reached the hard limit. An emergency stop has been executed automatically. To remove the module from this position you need to follow the procedure described in \"PowerCube Operation System: Disorder\"."),
    f("STATE_BEYOND_SOFT", state::BEYOND_SOFT, Error, Some("beyond-soft"), "This flag indicates the module has reached the soft limit. An emergency stop has been executed automatically. This flag can be reset by a Reset command."),
    f("STATE_LOGIC_VOLT", state::LOGIC_VOLT, Error, Some("logic-volt"), "The voltage of the logic power supply has either dropped or an overvoltage occurred. The drive will be disabled. This error can be reset."),
    f("STATE_POW_SETUP_ERR", state::POW_SETUP_ERR, Error, Some("pow-setup-err"), "Error in initializing the current controller. Module settings disaccord with controller configuration (5A/10A types). Power must be switched off. Please consult your service partner. Available from version 3.5.14 through 3.5.1D."),
];

/// Short state masks (manual 4.5.1).
pub mod short {
    /// `SHORT_NOT_OK`
    pub const NOT_OK: u8 = 0x01;
    /// `SHORT_SWR`
    pub const SWR: u8 = 0x02;
    /// `SHORT_SW1`
    pub const SW1: u8 = 0x04;
    /// `SHORT_SW2`
    pub const SW2: u8 = 0x08;
    /// `SHORT_MOTION`
    pub const MOTION: u8 = 0x10;
    /// `SHORT_RAMP_END`
    pub const RAMP_END: u8 = 0x20;
    /// `SHORT_INPROGRESS`
    pub const INPROGRESS: u8 = 0x40;
    /// `SHORT_FULLBUFFER`
    pub const FULLBUFFER: u8 = 0x80;
}

// SHORT_NOT_OK is a warning, not an error: a module that is merely not homed
// sets it too.
const SHORT_STATE_FLAGS: &[FlagDef] = &[
    f(
        "SHORT_NOT_OK",
        short::NOT_OK as u32,
        Warning,
        Some("not-ok"),
        "Set when STATE_ERROR OR NOT STATE_HOME_OK OR STATE_HALTED",
    ),
    f("SHORT_SWR", short::SWR as u32, Info, Some("swr"), "Copy of STATE_SWR"),
    f("SHORT_SW1", short::SW1 as u32, Info, Some("sw1"), "Copy of STATE_SW1"),
    f("SHORT_SW2", short::SW2 as u32, Info, Some("sw2"), "Copy of STATE_SW2"),
    f("SHORT_MOTION", short::MOTION as u32, Info, Some("motion"), "Copy of STATE_MOTION"),
    f("SHORT_RAMP_END", short::RAMP_END as u32, Info, Some("ramp-end"), "Copy of STATE_RAMP_END"),
    f("SHORT_INPROGRESS", short::INPROGRESS as u32, Info, Some("inprogress"), "Copy of STATE_INPROGRESS"),
    f("SHORT_FULLBUFFER", short::FULLBUFFER as u32, Info, Some("fullbuffer"), "Copy of STATE_FULLBUFFER"),
];

/// DIO byte masks of the extended acknowledge (manual 4.5.2).
pub mod dio {
    /// `INBIT0`
    pub const INBIT0: u8 = 0x01;
    /// `INBIT1`
    pub const INBIT1: u8 = 0x02;
    /// `INBIT2`
    pub const INBIT2: u8 = 0x04;
    /// `INBIT3`
    pub const INBIT3: u8 = 0x08;
    /// `OUTBIT0`
    pub const OUTBIT0: u8 = 0x10;
    /// `OUTBIT1`
    pub const OUTBIT1: u8 = 0x20;
    /// `OUTBIT2`
    pub const OUTBIT2: u8 = 0x40;
    /// `OUTBIT3`
    pub const OUTBIT3: u8 = 0x80;
}

const DIO_FLAGS: &[FlagDef] = &[
    f("INBIT0", dio::INBIT0 as u32, Info, Some("inbit0"), "State of input 0"),
    f("INBIT1", dio::INBIT1 as u32, Info, Some("inbit1"), "State of input 1"),
    f("INBIT2", dio::INBIT2 as u32, Info, Some("inbit2"), "State of input 2"),
    f("INBIT3", dio::INBIT3 as u32, Info, Some("inbit3"), "State of input 3"),
    f("OUTBIT0", dio::OUTBIT0 as u32, Info, Some("outbit0"), "State of output 0"),
    f("OUTBIT1", dio::OUTBIT1 as u32, Info, Some("outbit1"), "State of output 1"),
    f("OUTBIT2", dio::OUTBIT2 as u32, Info, Some("outbit2"), "State of output 2"),
    f("OUTBIT3", dio::OUTBIT3 as u32, Info, Some("outbit3"), "State of output 3"),
];

/// DioSetup word masks (manual 6).
pub mod dio_setup {
    /// `DIOID_MOD_INBIT0`
    pub const INBIT0: u32 = 0x00000001;
    /// `DIOID_MOD_INBIT1`
    pub const INBIT1: u32 = 0x00000002;
    /// `DIOID_MOD_INBIT2`
    pub const INBIT2: u32 = 0x00000004;
    /// `DIOID_MOD_INBIT3`
    pub const INBIT3: u32 = 0x00000008;
    /// `DIOID_MOD_OUTBIT0`
    pub const OUTBIT0: u32 = 0x00000010;
    /// `DIOID_MOD_OUTBIT1`
    pub const OUTBIT1: u32 = 0x00000020;
    /// `DIOID_MOD_OUTBIT2`
    pub const OUTBIT2: u32 = 0x00000040;
    /// `DIOID_MOD_OUTBIT3`
    pub const OUTBIT3: u32 = 0x00000080;
    /// `DIOID_MOD_INSWR`
    pub const INSWR: u32 = 0x00000100;
    /// `DIOID_MOD_INSW1`
    pub const INSW1: u32 = 0x00000200;
    /// `DIOID_MOD_INSW2`
    pub const INSW2: u32 = 0x00000400;
}

const DIO_SETUP_FLAGS: &[FlagDef] = &[
    f("DIOID_MOD_INBIT0", dio_setup::INBIT0, Info, Some("inbit0"), "State of input 0."),
    f("DIOID_MOD_INBIT1", dio_setup::INBIT1, Info, Some("inbit1"), "State of input 1."),
    f("DIOID_MOD_INBIT2", dio_setup::INBIT2, Info, Some("inbit2"), "State of input 2."),
    f("DIOID_MOD_INBIT3", dio_setup::INBIT3, Info, Some("inbit3"), "State of input 3."),
    f("DIOID_MOD_OUTBIT0", dio_setup::OUTBIT0, Info, Some("outbit0"), "State of output 0."),
    f("DIOID_MOD_OUTBIT1", dio_setup::OUTBIT1, Info, Some("outbit1"), "State of output 1."),
    f("DIOID_MOD_OUTBIT2", dio_setup::OUTBIT2, Info, Some("outbit2"), "State of output 2."),
    f("DIOID_MOD_OUTBIT3", dio_setup::OUTBIT3, Info, Some("outbit3"), "State of output 3."),
    f("DIOID_MOD_INSWR", dio_setup::INSWR, Info, Some("inswr"), "State of Home switch (1 = active)."),
    f("DIOID_MOD_INSW1", dio_setup::INSW1, Info, Some("insw1"), "State of Limit switch 1 (1 = active)."),
    f("DIOID_MOD_INSW2", dio_setup::INSW2, Info, Some("insw2"), "State of Limit switch 2 (1 = active)."),
];

/// Setup word masks (manual 7.1).
pub mod setup {
    /// `SETUPID_MOD_ENCODER_FEEDBACK`
    pub const ENCODER_FEEDBACK: u32 = 0x00000001;
    /// `SETUPID_MOD_RESOLVER_FEEDBACK`
    pub const RESOLVER_FEEDBACK: u32 = 0x00000002;
    /// `SETUPID_MOD_ABSOLUTE_FEEDBACK`
    pub const ABSOLUTE_FEEDBACK: u32 = 0x00000004;
    /// `SETUPID_MOD_4IN_4OUT`
    pub const MOD_4IN_4OUT: u32 = 0x00000008;
    /// `SETUPID_MOD_3IN_ENCODER_IN`
    pub const MOD_3IN_ENCODER_IN: u32 = 0x00000010;
    /// `SETUPID_MOD_3IN_ENCODER_OUT`
    pub const MOD_3IN_ENCODER_OUT: u32 = 0x00000020;
    /// `SETUPID_MOD_RS232`
    pub const RS232: u32 = 0x00000040;
    /// `SETUPID_MOD_CAN`
    pub const CAN: u32 = 0x00000200;
    /// `SETUPID_MOD_PROFIBUS`
    pub const PROFIBUS: u32 = 0x00000400;
    /// `SETUPID_MOD_USE_M3ID`
    pub const USE_M3ID: u32 = 0x00000800;
    /// `SETUPID_MOD_USE_M4ID`
    pub const USE_M4ID: u32 = 0x00001000;
    /// `SETUPID_MOD_USE_CANOPEN`
    pub const USE_CANOPEN: u32 = 0x00002000;
    /// `SETUPID_MOD_USE_SW2_AS_ENABLE`
    pub const USE_SW2_AS_ENABLE: u32 = 0x00008000;
    /// `SETUPID_MOD_USE_SW2_AS_BRAKE`
    pub const USE_SW2_AS_BRAKE: u32 = 0x00010000;
    /// `SETUPID_MOD_ERROR_TO_OUT0`
    pub const ERROR_TO_OUT0: u32 = 0x00020000;
}

const SETUP_FLAGS: &[FlagDef] = &[
    f("SETUPID_MOD_ENCODER_FEEDBACK", setup::ENCODER_FEEDBACK, Obsolete, Some("encoder-feedback"), "not used"),
    f("SETUPID_MOD_RESOLVER_FEEDBACK", setup::RESOLVER_FEEDBACK, Obsolete, Some("resolver-feedback"), "not used"),
    f("SETUPID_MOD_ABSOLUTE_FEEDBACK", setup::ABSOLUTE_FEEDBACK, Obsolete, Some("absolute-feedback"), "not used"),
    f(
        "SETUPID_MOD_4IN_4OUT",
        setup::MOD_4IN_4OUT,
        Info,
        Some("4in-4out"),
        "1 = The 15pole connector is configured for 4 I/O-Signals.",
    ),
    f(
        "SETUPID_MOD_3IN_ENCODER_IN",
        setup::MOD_3IN_ENCODER_IN,
        Info,
        Some("3in-encoder-in"),
        "1 = The 15pole connector is configured for Encoder input.",
    ),
    f(
        "SETUPID_MOD_3IN_ENCODER_OUT",
        setup::MOD_3IN_ENCODER_OUT,
        Info,
        Some("3in-encoder-out"),
        "1 = The 15pole connector is configured for Encoder output.",
    ),
    f("SETUPID_MOD_RS232", setup::RS232, Info, Some("rs232"), "1 = RS232 communication is active."),
    f("SETUPID_MOD_CAN", setup::CAN, Info, Some("can"), "1 = CAN communication is active."),
    f("SETUPID_MOD_PROFIBUS", setup::PROFIBUS, Info, Some("profibus"), "1 = Profibus communication is active."),
    f("SETUPID_MOD_USE_M3ID", setup::USE_M3ID, Info, Some("use-m3id"), "1 = CAN identifiers for MoRSE3 are active."),
    f("SETUPID_MOD_USE_M4ID", setup::USE_M4ID, Info, Some("use-m4id"), "1 = CAN identifiers for MoRSE4 are active."),
    f("SETUPID_MOD_USE_CANOPEN", setup::USE_CANOPEN, Info, Some("use-canopen"), "1 = The CANopen interface is active."),
    f(
        "SETUPID_MOD_USE_SW2_AS_ENABLE",
        setup::USE_SW2_AS_ENABLE,
        Info,
        Some("use-sw2-as-enable"),
        "1 = Input for Limit switch 2 is used as an Enable signal.",
    ),
    f(
        "SETUPID_MOD_USE_SW2_AS_BRAKE",
        setup::USE_SW2_AS_BRAKE,
        Info,
        Some("use-sw2-as-brake"),
        "1 = Input for Limit switch 2 is used as Release brake signal.",
    ),
    f(
        "SETUPID_MOD_ERROR_TO_OUT0",
        setup::ERROR_TO_OUT0,
        Info,
        Some("error-to-out0"),
        "1 = An error will be signaled on output 0.",
    ),
];

/// Config word masks (manual 7.2).
pub mod config {
    /// `CONFIGID_MOD_BRAKE_PRESENT`
    pub const BRAKE_PRESENT: u32 = 0x00000008;
    /// `CONFIGID_MOD_BRAKE_AT_POWERON`
    pub const BRAKE_AT_POWERON: u32 = 0x00000010;
    /// `CONFIGID_MOD_SWR_WITH_ENCODERZERO`
    pub const SWR_WITH_ENCODERZERO: u32 = 0x00000020;
    /// `CONFIGID_MOD_SWR_AT_FALLING_EDGE`
    pub const SWR_AT_FALLING_EDGE: u32 = 0x00000040;
    /// `CONFIGID_MOD_CHANGE_SWR_TO_LIMIT`
    pub const CHANGE_SWR_TO_LIMIT: u32 = 0x00000080;
    /// `CONFIGID_MOD_SWR_ENABLED`
    pub const SWR_ENABLED: u32 = 0x00000100;
    /// `CONFIGID_MOD_SWR_LOW_ACTIVE`
    pub const SWR_LOW_ACTIVE: u32 = 0x00000200;
    /// `CONFIGID_MOD_SWR_USE_EXTERNAL`
    pub const SWR_USE_EXTERNAL: u32 = 0x00000400;
    /// `CONFIGID_MOD_SW1_ENABLED`
    pub const SW1_ENABLED: u32 = 0x00000800;
    /// `CONFIGID_MOD_SW1_LOW_ACTIVE`
    pub const SW1_LOW_ACTIVE: u32 = 0x00001000;
    /// `CONFIGID_MOD_SW1_USE_EXTERNAL`
    pub const SW1_USE_EXTERNAL: u32 = 0x00002000;
    /// `CONFIGID_MOD_SW2_ENABLED`
    pub const SW2_ENABLED: u32 = 0x00004000;
    /// `CONFIGID_MOD_SW2_LOW_ACTIVE`
    pub const SW2_LOW_ACTIVE: u32 = 0x00008000;
    /// `CONFIGID_MOD_SW2_USE_EXTERNAL`
    pub const SW2_USE_EXTERNAL: u32 = 0x00010000;
    /// `CONFIGID_MOD_LINEAR`
    pub const LINEAR: u32 = 0x00020000;
    /// `CONFIGID_MOD_ALLOW_FULL_CUR`
    pub const ALLOW_FULL_CUR: u32 = 0x00080000;
    /// `CONFIGID_MOD_M3_COMPATIBLE`
    pub const M3_COMPATIBLE: u32 = 0x00100000;
    /// `CONFIGID_MOD_LINEAR_SCREW`
    pub const LINEAR_SCREW: u32 = 0x00200000;
    /// `CONFIGID_MOD_DISABLE_ON_HALT`
    pub const DISABLE_ON_HALT: u32 = 0x00800000;
    /// `CONFIGID_MOD_WATCHDOG_ENABLE`
    pub const WATCHDOG_ENABLE: u32 = 0x01000000;
    /// `CONFIGID_MOD_ZERO_MOVE_AFTER_HOK`
    pub const ZERO_MOVE_AFTER_HOK: u32 = 0x02000000;
    /// `CONFIGID_MOD_DISABLE_ACK`
    pub const DISABLE_ACK: u32 = 0x04000000;
    /// `CONFIGID_MOD_SYNC_MOTION`
    pub const SYNC_MOTION: u32 = 0x08000000;
}

const CONFIG_FLAGS: &[FlagDef] = &[
    f("CONFIGID_MOD_BRAKE_PRESENT", config::BRAKE_PRESENT, Info, Some("brake-present"), "1 = Brake is present"),
    f("CONFIGID_MOD_BRAKE_AT_POWERON", config::BRAKE_AT_POWERON, Info, Some("brake-at-poweron"), "0 = Brake is released on power on"),
    f("CONFIGID_MOD_SWR_WITH_ENCODERZERO", config::SWR_WITH_ENCODERZERO, Info, Some("swr-with-encoderzero"), "1 = Encoderindex signal is used in homing procedure"),
    f("CONFIGID_MOD_SWR_AT_FALLING_EDGE", config::SWR_AT_FALLING_EDGE, Info, Some("swr-at-falling-edge"), "1 = Homing on falling edge of limit switch"),
    f("CONFIGID_MOD_CHANGE_SWR_TO_LIMIT", config::CHANGE_SWR_TO_LIMIT, Info, Some("change-swr-to-limit"), "1 = Home switch is limit switch (except during Homing)"),
    f("CONFIGID_MOD_SWR_ENABLED", config::SWR_ENABLED, Info, Some("swr-enabled"), "1 = Home switch is enabled"),
    f("CONFIGID_MOD_SWR_LOW_ACTIVE", config::SWR_LOW_ACTIVE, Info, Some("swr-low-active"), "1 = Home switch is low active"),
    f("CONFIGID_MOD_SWR_USE_EXTERNAL", config::SWR_USE_EXTERNAL, Info, Some("swr-use-external"), "1 = External home switch is used"),
    f("CONFIGID_MOD_SW1_ENABLED", config::SW1_ENABLED, Info, Some("sw1-enabled"), "1 = Limit switch 1 is enabled"),
    f("CONFIGID_MOD_SW1_LOW_ACTIVE", config::SW1_LOW_ACTIVE, Info, Some("sw1-low-active"), "1 = Limit switch 1 is low active"),
    f("CONFIGID_MOD_SW1_USE_EXTERNAL", config::SW1_USE_EXTERNAL, Info, Some("sw1-use-external"), "1 = External limit switch 1 is used"),
    f("CONFIGID_MOD_SW2_ENABLED", config::SW2_ENABLED, Info, Some("sw2-enabled"), "1 = Limit switch 2 is enabled"),
    f("CONFIGID_MOD_SW2_LOW_ACTIVE", config::SW2_LOW_ACTIVE, Info, Some("sw2-low-active"), "1 = Limit switch 2 is low active"),
    f("CONFIGID_MOD_SW2_USE_EXTERNAL", config::SW2_USE_EXTERNAL, Info, Some("sw2-use-external"), "1 = External Limit switch 2 is used"),
    f("CONFIGID_MOD_LINEAR", config::LINEAR, Info, Some("linear"), "1 = Module is a linear type"),
    f("CONFIGID_MOD_ALLOW_FULL_CUR", config::ALLOW_FULL_CUR, Info, Some("allow-full-cur"), "0 = Commanded current (PCube_moveCur) is limited to nominal current."),
    f("CONFIGID_MOD_M3_COMPATIBLE", config::M3_COMPATIBLE, Info, Some("m3-compatible"), "1 = Module is M3 compatible. This concerns CAN communication and behaviour at PCube_moveStep. Module does not accept motion commands unless successfully homed."),
    f("CONFIGID_MOD_LINEAR_SCREW", config::LINEAR_SCREW, Info, Some("linear-screw"), "1 = Module is linear, driven by ball screw."),
    f("CONFIGID_MOD_DISABLE_ON_HALT", config::DISABLE_ON_HALT, Info, Some("disable-on-halt"), "1 = Motor power disabled In case of error"),
    f("CONFIGID_MOD_WATCHDOG_ENABLE", config::WATCHDOG_ENABLE, Info, Some("watchdog-enable"), "1 = Watchdog is enabled. Activated automatically by the first \"life sign\" of the host control."),
    f("CONFIGID_MOD_ZERO_MOVE_AFTER_HOK", config::ZERO_MOVE_AFTER_HOK, Info, Some("zero-move-after-hok"), "1 = After Homing the module moves to zero"),
    f("CONFIGID_MOD_DISABLE_ACK", config::DISABLE_ACK, Info, Some("disable-ack"), "1 = All acknowledge messages are disabled. All Get commands will still be acknowledged. Valid only for CAN-Bus."),
    f("CONFIGID_MOD_SYNC_MOTION", config::SYNC_MOTION, Info, Some("sync-motion"), "1 = Synchronized motion commands enabled. After sending a motion command the drive expects the broadcast PCube_startMotionAll to start motion. Valid only for CAN-Bus."),
];

/// Profibus-DP short state masks (manual 4.2.1).
pub mod profibus {
    /// `STATE_ERRORM4`
    pub const ERRORM4: u16 = 0x0001;
    /// `STATE_READYTOPOS`
    pub const READYTOPOS: u16 = 0x0004;
    /// `STATE_MOVING`
    pub const MOVING: u16 = 0x0010;
    /// `STATE_BRAKED`
    pub const BRAKED: u16 = 0x0020;
    /// `STATE_CURRLIMIT`
    pub const CURRLIMIT: u16 = 0x0040;
    /// `STATE_ENDMOTION`
    pub const ENDMOTION: u16 = 0x0080;
    /// `STATE_END0`
    pub const END0: u16 = 0x0100;
    /// `STATE_END1`
    pub const END1: u16 = 0x0200;
    /// `STATE_SYNC`
    pub const SYNC: u16 = 0x0400;
    /// `POSTIME_INPROGRESS_MASK`
    pub const POSTIME_INPROGRESS_MASK: u16 = 0x1000;
    /// `POSTIME_RECEIVED_MASK`
    pub const POSTIME_RECEIVED_MASK: u16 = 0x2000;
    /// `STATE_HALTM4`
    pub const HALTM4: u16 = 0x8000;
}

const PROFIBUS_STATE_FLAGS: &[FlagDef] = &[
    f("STATE_ERRORM4", profibus::ERRORM4 as u32, Error, Some("errorm4"), "Copy of STATE_ERROR"),
    f("STATE_READYTOPOS", profibus::READYTOPOS as u32, Info, Some("readytopos"), "Copy of STATE_HOME_OK"),
    f("STATE_MOVING", profibus::MOVING as u32, Info, Some("moving"), "Copy of STATE_MOTION"),
    f("STATE_BRAKED", profibus::BRAKED as u32, Info, Some("braked"), "Copy of STATE_BRAKEACTIVE"),
    f("STATE_CURRLIMIT", profibus::CURRLIMIT as u32, Warning, Some("currlimit"), "Copy of STATE_CURLIMIT"),
    f("STATE_ENDMOTION", profibus::ENDMOTION as u32, Info, Some("endmotion"), "Copy of STATE_RAMP_END"),
    f("STATE_END0", profibus::END0 as u32, Info, Some("end0"), "Copy of STATE_SW1"),
    f("STATE_END1", profibus::END1 as u32, Info, Some("end1"), "Copy of STATE_SW2"),
    f("STATE_SYNC", profibus::SYNC as u32, Info, Some("sync"), "Copy of STATE_SWR"),
    f(
        "POSTIME_INPROGRESS_MASK",
        profibus::POSTIME_INPROGRESS_MASK as u32,
        Info,
        Some("inprogress"),
        "Copy of STATE_INPROGRESS",
    ),
    f(
        "POSTIME_RECEIVED_MASK",
        profibus::POSTIME_RECEIVED_MASK as u32,
        Info,
        Some("received"),
        "Copy of STATE_FULLBUFFER",
    ),
    f("STATE_HALTM4", profibus::HALTM4 as u32, Info, Some("haltm4"), "Copy of STATE_HALTED"),
];

/// CubeState, parameter 0x27 (manual 5).
pub const CUBE_STATE: FlagWord = FlagWord { kind: "cube-state", name: "CubeState", bits: 32, flags: CUBE_STATE_FLAGS };
/// Short state byte of the extended motion acknowledge and ActFPosStateDio (manual 4.5.1).
pub const SHORT_STATE: FlagWord =
    FlagWord { kind: "short-state", name: "short state", bits: 8, flags: SHORT_STATE_FLAGS };
/// DIO byte of the extended motion acknowledge and ActFPosStateDio (manual 4.5.2).
pub const DIO: FlagWord = FlagWord { kind: "dio", name: "DIO", bits: 8, flags: DIO_FLAGS };
/// DioSetup, parameter 0x26 (manual 6).
pub const DIO_SETUP: FlagWord = FlagWord { kind: "dio-setup", name: "DioSetup", bits: 32, flags: DIO_SETUP_FLAGS };
/// Setup, parameter 0x58 (manual 7.1).
pub const SETUP: FlagWord = FlagWord { kind: "setup", name: "Setup", bits: 32, flags: SETUP_FLAGS };
/// Config, parameter 0x39, and DefConfig 0x1b (manual 7.2).
pub const CONFIG: FlagWord = FlagWord { kind: "config", name: "Config", bits: 32, flags: CONFIG_FLAGS };
/// Profibus-DP short state, input bytes 13..14 (manual 4.2.1).
pub const PROFIBUS_STATE: FlagWord =
    FlagWord { kind: "profibus-state", name: "Profibus short state", bits: 16, flags: PROFIBUS_STATE_FLAGS };

/// Every word, for lookup by `kind`.
pub const WORDS: &[&FlagWord] = &[&CUBE_STATE, &SHORT_STATE, &DIO, &DIO_SETUP, &SETUP, &CONFIG, &PROFIBUS_STATE];

/// The word whose `kind` is `kind` (any case).
pub fn word(kind: &str) -> Option<&'static FlagWord> {
    WORDS.iter().copied().find(|w| w.kind.eq_ignore_ascii_case(kind.trim()))
}

/// The word a parameter holds, where it is a flag word.
pub fn word_for_param(id: u8) -> Option<&'static FlagWord> {
    use super::table::ids;
    match id {
        ids::CUBE_STATE => Some(&CUBE_STATE),
        ids::DIO_SETUP => Some(&DIO_SETUP),
        ids::SETUP => Some(&SETUP),
        ids::CONFIG | ids::DEF_CONFIG => Some(&CONFIG),
        _ => None,
    }
}

/// The CubeState flag each short-state bit copies (manual 4.5.1); bit 0,
/// SHORT_NOT_OK, is derived instead.
pub const SHORT_FROM_CUBE: &[(u8, u32)] = &[
    (short::SWR, state::SWR),
    (short::SW1, state::SW1),
    (short::SW2, state::SW2),
    (short::MOTION, state::MOTION),
    (short::RAMP_END, state::RAMP_END),
    (short::INPROGRESS, state::INPROGRESS),
    (short::FULLBUFFER, state::FULLBUFFER),
];

/// The CubeState flag each Profibus short-state bit copies (manual 4.2.1).
pub const PROFIBUS_FROM_CUBE: &[(u16, u32)] = &[
    (profibus::ERRORM4, state::ERROR),
    (profibus::READYTOPOS, state::HOME_OK),
    (profibus::MOVING, state::MOTION),
    (profibus::BRAKED, state::BRAKEACTIVE),
    (profibus::CURRLIMIT, state::CURLIMIT),
    (profibus::ENDMOTION, state::RAMP_END),
    (profibus::END0, state::SW1),
    (profibus::END1, state::SW2),
    (profibus::SYNC, state::SWR),
    (profibus::POSTIME_INPROGRESS_MASK, state::INPROGRESS),
    (profibus::POSTIME_RECEIVED_MASK, state::FULLBUFFER),
    (profibus::HALTM4, state::HALTED),
];

/// The short state a module reports for CubeState `cube` (manual 4.5.1):
/// SHORT_NOT_OK = ERROR or not HOME_OK or HALTED, the rest copied.
pub fn short_state_from_cube_state(cube: u32) -> u8 {
    let not_ok = cube & state::ERROR != 0 || cube & state::HOME_OK == 0 || cube & state::HALTED != 0;
    let copied = SHORT_FROM_CUBE.iter().filter(|(_, c)| cube & c != 0).fold(0, |acc, (s, _)| acc | s);
    copied | if not_ok { short::NOT_OK } else { 0 }
}

/// The Profibus-DP short state for CubeState `cube` (manual 4.2.1).
pub fn profibus_state_from_cube_state(cube: u32) -> u16 {
    PROFIBUS_FROM_CUBE.iter().filter(|(_, c)| cube & c != 0).fold(0, |acc, (p, _)| acc | p)
}

/// Bytes a module presents to a Profibus-DP master.
pub const PROFIBUS_INPUT_LEN: usize = 16;

/// The 16 Profibus-DP input bytes (manual 4.2.1 and 10): the answer to the
/// last command, then position, short state and a millisecond counter.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub struct ProfibusInput {
    /// Bytes 0..=7: the answer payload, padded with whatever the module left there.
    pub answer: [u8; 8],
    /// Byte 8, unused by the manual; kept so an image re-encodes unchanged.
    pub reserved: u8,
    /// Bytes 9..=12: actual position in encoder ticks.
    pub position_ticks: i32,
    /// Bytes 13..=14: [`PROFIBUS_STATE`] flags.
    pub short_state: u16,
    /// Byte 15: milliseconds 0..=255, a life sign.
    pub ms: u8,
}

impl ProfibusInput {
    /// Parses exactly [`PROFIBUS_INPUT_LEN`] bytes.
    pub fn decode(bytes: &[u8]) -> Result<Self, DecodeError> {
        let b: &[u8; PROFIBUS_INPUT_LEN] = bytes.try_into().map_err(|_| {
            if bytes.len() < PROFIBUS_INPUT_LEN {
                DecodeError::TooShort { need: PROFIBUS_INPUT_LEN, got: bytes.len() }
            } else {
                DecodeError::TooLong { len: bytes.len() }
            }
        })?;
        let mut answer = [0; 8];
        answer.copy_from_slice(&b[..8]);
        Ok(Self {
            answer,
            reserved: b[8],
            position_ticks: i32::from_le_bytes([b[9], b[10], b[11], b[12]]),
            short_state: u16::from_le_bytes([b[13], b[14]]),
            ms: b[15],
        })
    }

    /// The 16 wire bytes.
    pub fn to_bytes(&self) -> [u8; PROFIBUS_INPUT_LEN] {
        let mut b = [0; PROFIBUS_INPUT_LEN];
        b[..8].copy_from_slice(&self.answer);
        b[8] = self.reserved;
        b[9..13].copy_from_slice(&self.position_ticks.to_le_bytes());
        b[13..15].copy_from_slice(&self.short_state.to_le_bytes());
        b[15] = self.ms;
        b
    }

    /// The short state taken apart.
    pub fn state(&self) -> Decoded {
        PROFIBUS_STATE.decode(self.short_state.into())
    }

    /// How many of the 8 answer bytes are the answer: the image has no length
    /// field, so it follows from the command, parameter and motion tables.
    pub fn answer_len(&self) -> Result<usize, DecodeError> {
        let [cmd, sub, ..] = self.answer;
        let cmd = CommandId::from_u8(cmd).ok_or(DecodeError::Unknown { what: "command id", value: cmd.into() })?;
        Ok(match cmd {
            CommandId::SetExtended => 3,
            CommandId::GetExtended => {
                2 + table::param(sub).ok_or(DecodeError::Unknown { what: "parameter id", value: sub.into() })?.ty.size()
            }
            CommandId::SetMotion => {
                let def = table::motion(sub).ok_or(DecodeError::Unknown { what: "motion id", value: sub.into() })?;
                if def.extended_ack {
                    8
                } else {
                    3
                }
            }
            CommandId::SavePos | CommandId::StartMotion => {
                return Err(DecodeError::Malformed(format!("{} is never acknowledged", cmd.name())))
            }
            _ => 1,
        })
    }

    /// The answer bytes as a payload.
    pub fn answer_payload(&self) -> Result<Payload, DecodeError> {
        let len = self.answer_len()?;
        Payload::new(&self.answer[..len]).ok_or(DecodeError::TooLong { len })
    }

    /// The answer as a typed acknowledge.
    pub fn response(&self) -> Result<Response, DecodeError> {
        Response::decode(self.answer_payload()?.as_slice())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn class_names_are_the_serde_names() {
        for c in [FlagClass::Error, FlagClass::Warning, FlagClass::Info, FlagClass::Obsolete] {
            assert_eq!(serde_json::to_value(c).unwrap(), c.name());
        }
    }

    /// Bit 27 of CubeState is the one bit the manual names twice.
    const SHARED: &[(&str, u32)] = &[("cube-state", state::LOGIC_VOLT)];

    #[test]
    fn tables_are_well_formed() {
        let mut kinds: Vec<_> = WORDS.iter().map(|w| w.kind).collect();
        kinds.sort();
        kinds.dedup();
        assert_eq!(kinds.len(), WORDS.len());
        for w in WORDS {
            assert!(matches!(w.bits, 8 | 16 | 32), "{}", w.kind);
            assert_eq!(word(&w.kind.to_uppercase()).map(|x| x.kind), Some(w.kind));
            for (i, d) in w.flags.iter().enumerate() {
                assert_eq!(d.mask.count_ones(), 1, "{} {}", w.kind, d.name);
                assert_eq!(d.mask & !w.width_mask(), 0, "{} {} beyond width", w.kind, d.name);
                assert!(!d.description.is_empty());
                for e in &w.flags[i + 1..] {
                    assert_ne!(d.name, e.name, "{}", w.kind);
                    assert!(d.short.is_none() || d.short != e.short, "{} {}", w.kind, d.name);
                    if d.mask == e.mask {
                        assert!(
                            SHARED.contains(&(w.kind, d.mask)),
                            "{}: {} and {} share a bit",
                            w.kind,
                            d.name,
                            e.name
                        );
                    }
                }
                // Lookup by either name finds this very row.
                assert!(std::ptr::eq(w.flag(&d.name.to_lowercase()).unwrap(), d));
                if let Some(s) = d.short {
                    assert!(std::ptr::eq(w.flag(&s.to_uppercase()).unwrap(), d));
                }
            }
        }
        assert_eq!(CUBE_STATE.flags.len(), 29);
        assert_eq!(CONFIG.flags.len(), 23);
        assert_eq!(SETUP.flags.len(), 15);
        assert_eq!(DIO_SETUP.flags.len(), 11);
        assert_eq!(PROFIBUS_STATE.flags.len(), 12);
    }

    #[test]
    fn cube_state_decodes_manual_values() {
        let d = CUBE_STATE.decode(0x0000_0002);
        assert_eq!(d.flags, ["STATE_HOME_OK"]);
        assert!(d.errors.is_empty());
        // Errata: bit 23 is POW_INTEGRAL_ERR, 0x00080000 is only POW_FET_TEMP.
        assert_eq!(CUBE_STATE.decode(0x0080_0000).flags, ["STATE_POW_INTEGRAL_ERR"]);
        assert_eq!(CUBE_STATE.decode(0x0008_0000).flags, ["STATE_POW_FET_TEMP"]);
        // Errata: bit 27 shows both names.
        let d = CUBE_STATE.decode(0x0800_0000);
        assert_eq!(d.flags, ["STATE_LOGIC_VOLT", "STATE_POW_SETUP_ERR"]);
        assert_eq!(d.errors, d.flags);
        let d = CUBE_STATE.decode(state::ERROR | state::POWERFAULT | state::POW_SHORTCUR | state::HOME_OK);
        assert_eq!(d.errors, ["STATE_ERROR", "STATE_POWERFAULT", "STATE_POW_SHORTCUR"]);
        assert!(d.has_error());
        let d = CUBE_STATE.decode(state::CURLIMIT | state::MOTION | 0x3000_0000);
        assert_eq!(d.warnings, ["STATE_CURLIMIT"]);
        assert!(!d.has_error());
        assert_eq!(d.unknown_bits, 0x3000_0000);
        assert_eq!(d.to_string(), "0x30000c00 STATE_CURLIMIT|STATE_MOTION unknown 0x30000000");
        let json = serde_json::to_value(CUBE_STATE.decode(0x0000_0011)).unwrap();
        assert_eq!(json["flags"], serde_json::json!(["STATE_ERROR", "STATE_TOW_ERROR"]));
        assert_eq!(json["errors"], serde_json::json!(["STATE_ERROR", "STATE_TOW_ERROR"]));
        assert_eq!(json["raw"], 0x11);
        assert_eq!(json["unknown_bits"], 0);
    }

    #[test]
    fn other_words_decode() {
        assert_eq!(DIO.decode(0x11).flags, ["INBIT0", "OUTBIT0"]);
        assert_eq!(DIO_SETUP.decode(0x0000_0500).flags, ["DIOID_MOD_INSWR", "DIOID_MOD_INSW2"]);
        let s = SETUP.decode(0x0000_0241);
        assert_eq!(s.flags, ["SETUPID_MOD_ENCODER_FEEDBACK", "SETUPID_MOD_RS232", "SETUPID_MOD_CAN"]);
        assert_eq!(SETUP.flag("encoder-feedback").map(|d| d.class), Some(FlagClass::Obsolete));
        // 0x100 is between SETUPID_MOD_RS232 and SETUPID_MOD_CAN: no name.
        assert_eq!(SETUP.decode(0x100).unknown_bits, 0x100);
        assert_eq!(CONFIG.decode(0x0100_0008).flags, ["CONFIGID_MOD_BRAKE_PRESENT", "CONFIGID_MOD_WATCHDOG_ENABLE"]);
        assert_eq!(CONFIG.decode(0x7).unknown_bits, 0x7);
        assert_eq!(SHORT_STATE.decode(0x21).flags, ["SHORT_NOT_OK", "SHORT_RAMP_END"]);
        assert_eq!(SHORT_STATE.decode(0x21).warnings, ["SHORT_NOT_OK"]);
        assert_eq!(SHORT_STATE.decode(0x100).unknown_bits, 0x100);
        assert_eq!(PROFIBUS_STATE.decode(0x8001).flags, ["STATE_ERRORM4", "STATE_HALTM4"]);
        assert_eq!(PROFIBUS_STATE.decode(0x8001).errors, ["STATE_ERRORM4"]);
        assert_eq!(word_for_param(0x27).map(|w| w.kind), Some("cube-state"));
        assert_eq!(word_for_param(0x1b).map(|w| w.kind), Some("config"));
        assert!(word_for_param(0x3c).is_none());
    }

    #[test]
    fn config_names_parse() {
        assert_eq!(CONFIG.flag("brake-present").map(|d| d.name), Some("CONFIGID_MOD_BRAKE_PRESENT"));
        assert_eq!(CONFIG.flag("configid_mod_brake_present").map(|d| d.mask), Some(config::BRAKE_PRESENT));
        assert_eq!(CONFIG.parse("brake-present|WATCHDOG-ENABLE"), Ok(0x0100_0008));
        assert_eq!(CONFIG.parse("brake-present, CONFIGID_MOD_SYNC_MOTION"), Ok(0x0800_0008));
        assert_eq!(CONFIG.parse("0x8"), Ok(8));
        assert_eq!(CONFIG.parse(""), Ok(0));
        assert!(matches!(CONFIG.parse("brake-present|nope"), Err(FlagParseError::UnknownFlag { .. })));
        assert!(matches!(SHORT_STATE.parse("0x100"), Err(FlagParseError::TooWide { .. })));
        assert!(matches!(CONFIG.parse("-1"), Err(FlagParseError::TooWide { .. })));
    }

    #[test]
    fn short_state_derivation() {
        // Not homed: NOT_OK.
        assert_eq!(short_state_from_cube_state(0), 0x01);
        assert_eq!(short_state_from_cube_state(state::HOME_OK), 0x00);
        assert_eq!(short_state_from_cube_state(state::HOME_OK | state::ERROR), 0x01);
        assert_eq!(short_state_from_cube_state(state::HOME_OK | state::HALTED), 0x01);
        let all = state::HOME_OK
            | state::SWR
            | state::SW1
            | state::SW2
            | state::MOTION
            | state::RAMP_END
            | state::INPROGRESS
            | state::FULLBUFFER;
        assert_eq!(short_state_from_cube_state(all), 0xfe);
        // Flags the short state does not carry.
        assert_eq!(short_state_from_cube_state(state::HOME_OK | state::RAMP_ACC | state::BRAKEACTIVE), 0);
        assert_eq!(short_state_from_cube_state(state::HOME_OK | state::RAMP_END), short::RAMP_END);
    }

    #[test]
    fn profibus_state_derivation() {
        assert_eq!(profibus_state_from_cube_state(0), 0);
        assert_eq!(profibus_state_from_cube_state(state::ERROR | state::HOME_OK | state::HALTED), 0x8005);
        assert_eq!(profibus_state_from_cube_state(state::SWR | state::SW1 | state::SW2), 0x0700);
        assert_eq!(profibus_state_from_cube_state(state::INPROGRESS | state::FULLBUFFER), 0x3000);
        assert_eq!(profibus_state_from_cube_state(state::TOW_ERROR), 0);
        // The mapping and the rows' descriptions agree.
        for (p, c) in PROFIBUS_FROM_CUBE {
            let pdef = PROFIBUS_STATE.set_flags(u32::from(*p)).next().unwrap();
            let cdef = CUBE_STATE.set_flags(*c).next().unwrap();
            assert_eq!(pdef.description, format!("Copy of {}", cdef.name));
        }
        for (s, c) in SHORT_FROM_CUBE {
            let sdef = SHORT_STATE.set_flags(u32::from(*s)).next().unwrap();
            let cdef = CUBE_STATE.set_flags(*c).next().unwrap();
            assert_eq!(sdef.description, format!("Copy of {}", cdef.name));
        }
    }

    fn image(answer: &[u8]) -> [u8; 16] {
        let mut b = [0u8; 16];
        b[..answer.len()].copy_from_slice(answer);
        b[9..13].copy_from_slice(&(-1000i32).to_le_bytes());
        b[13..15].copy_from_slice(&0x8085u16.to_le_bytes());
        b[15] = 200;
        b
    }

    #[test]
    fn profibus_input_image() {
        // Manual 10: answer to "Set Ramp motion acceleration", [08 50 64].
        let img = ProfibusInput::decode(&image(&[0x08, 0x50, 0x64, 0xaa])).unwrap();
        assert_eq!(img.position_ticks, -1000);
        assert_eq!(img.short_state, 0x8085);
        assert_eq!(img.ms, 200);
        assert_eq!(img.state().flags, ["STATE_ERRORM4", "STATE_READYTOPOS", "STATE_ENDMOTION", "STATE_HALTM4"]);
        assert_eq!(img.response(), Ok(Response::SetAck { param: 0x50 }));
        // GetExtended of ActPos: 2 + 4 bytes; the rest is padding.
        let mut get = vec![0x0a, 0x3c];
        get.extend_from_slice(&0.75f32.to_le_bytes());
        get.extend_from_slice(&[0xee, 0xee]);
        let img = ProfibusInput::decode(&image(&get)).unwrap();
        assert_eq!(img.answer_len(), Ok(6));
        assert!(matches!(img.response(), Ok(Response::Get { param: 0x3c, data }) if data.as_slice() == &get[2..6]));
        // Home and extended motion acks.
        assert_eq!(
            ProfibusInput::decode(&image(&[0x01, 0x99])).unwrap().response(),
            Ok(Response::Simple(CommandId::Home))
        );
        let ext = [0x0b, 14, 0, 0, 0x40, 0x3f, 0x20, 0x11];
        assert!(matches!(
            ProfibusInput::decode(&image(&ext)).unwrap().response(),
            Ok(Response::MotionAckExt { motion: 14, short_state: 0x20, dio: 0x11, .. })
        ));
        assert!(ProfibusInput::decode(&image(&[0x0a, 0x11])).unwrap().response().is_err());
        assert!(matches!(ProfibusInput::decode(&[0; 15]), Err(DecodeError::TooShort { need: 16, got: 15 })));
        assert!(matches!(ProfibusInput::decode(&[0; 17]), Err(DecodeError::TooLong { len: 17 })));
    }

    proptest! {
        #[test]
        fn decode_accounts_for_every_bit(raw in any::<u32>(), w in 0..WORDS.len()) {
            let word = WORDS[w];
            let d = word.decode(raw);
            let named = d.flags.iter().map(|n| word.flag(n).unwrap().mask).fold(0, |a, m| a | m);
            prop_assert_eq!(named | d.unknown_bits, raw);
            prop_assert_eq!(named & d.unknown_bits, 0);
            prop_assert_eq!(word.parse(&d.flags.join("|")).unwrap(), named);
        }

        #[test]
        fn profibus_input_never_panics(
            bytes in prop_oneof![proptest::collection::vec(any::<u8>(), 16), proptest::collection::vec(any::<u8>(), 0..40)]
        ) {
            if let Ok(img) = ProfibusInput::decode(&bytes) {
                prop_assert_eq!(&img.to_bytes()[..], &bytes[..]);
                let _ = img.response();
            }
        }

        #[test]
        fn short_state_not_ok_rule(cube in any::<u32>()) {
            let s = short_state_from_cube_state(cube);
            let bad = cube & (state::ERROR | state::HALTED) != 0 || cube & state::HOME_OK == 0;
            prop_assert_eq!(s & short::NOT_OK != 0, bad);
        }
    }
}
