//! `axisctl sim` options, as typed.

use clap::Args;

use super::ids::{self, IdList};
use axisctl::family::{CDIOS_FACTORY_NODE, CDIOS_MODULE, CDIOS_NODE, PAC_AXIS, POWERCUBE_MODULE};

#[derive(Debug, Args)]
pub struct SimArgs {
    /// Serve PowerCube modules: pty-serial, pty-slcan or socketcan:IFACE
    #[arg(long, value_name = "WHERE")]
    pub powercube: Option<String>,
    /// Serve the PA-CONTROL: pty-serial
    #[arg(long, value_name = "WHERE")]
    pub pac: Option<String>,
    /// Serve the Cdios node: pty-slcan or socketcan:IFACE
    #[arg(long, value_name = "WHERE")]
    pub cdios: Option<String>,
    /// Serve the CAN bus (PowerCube modules and the Cdios node) as a socketcand daemon does, bus can0, at HOST:PORT (port 0: any free port); the link printed is socketcand:HOST:PORT/can0
    #[arg(long, value_name = "ADDR")]
    pub socketcand: Option<String>,
    /// PowerCube module addresses, e.g. 3,5,17 or 1-8 (empty: none)
    #[arg(short = 'm', long = "module", alias = "modules", value_name = "LIST", default_value = "3,5,17",
          value_parser = ids::list_or_none(POWERCUBE_MODULE))]
    pub modules: IdList,
    /// Which of them are linear (the others rotary)
    #[arg(long, value_name = "LIST", default_value = "17", value_parser = ids::list_or_none(POWERCUBE_MODULE))]
    pub linear: IdList,
    /// How many axes the simulated PA-CONTROL has configured (axes 1 to N)
    #[arg(long, value_name = "N", default_value_t = 3, value_parser = ids::id(PAC_AXIS))]
    pub axes: u8,
    /// Cdios node id
    #[arg(long, default_value_t = CDIOS_FACTORY_NODE, value_parser = ids::id(CDIOS_NODE))]
    pub node: u8,
    /// Cdios 6168 module ids, e.g. 0,1 (empty: none)
    #[arg(long = "cdios-module", alias = "cdios-modules", value_name = "LIST", default_value = "0,1",
          value_parser = ids::list_or_none(CDIOS_MODULE))]
    pub cdios_modules: IdList,
    /// Run the simulated lines at their real speed: serial at --baud, CAN at --bitrate
    #[arg(long)]
    pub wire_speed: bool,
    /// Baud rate of the served serial lines (with --wire-speed)
    #[arg(long, default_value_t = 9600)]
    pub baud: u32,
    /// CAN bitrate of the simulated bus (with --wire-speed)
    #[arg(long, default_value_t = 1_000_000)]
    pub bitrate: u32,
    /// Inject faults into the devices' answers, e.g. drop=0.2,delay=150ms,garbage=0.1,truncate=0.05,duplicate=0.1,wrong-module=0.05 (also delay=DUR@P, skip=N, count=N, trip=DUR: fault a device moving that long; overshoot=PCT, slow-halt=DUR: PowerCube ramps and PA-CONTROL positionings ring PCT % past their target, a halt or stop brakes over DUR)
    #[arg(long, value_name = "SPEC")]
    pub fault: Option<String>,
    /// Seed of the fault decisions: the same seed replays the same faults
    #[arg(long, value_name = "N", default_value_t = 1, requires = "fault")]
    pub fault_seed: u64,
}
