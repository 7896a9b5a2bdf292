//! `axisctl dashboard` options, as typed.

use clap::Args;

use super::ids::{self, IdList};
use axisctl::bench::DeviceRef;
use axisctl::family::{Family, CDIOS_FACTORY_NODE, CDIOS_MODULE, CDIOS_NODE, PAC_AXIS, POWERCUBE_MODULE};

#[derive(Debug, Args)]
pub struct DashboardArgs {
    /// Polls per second wanted on each link (the status bar shows what each achieves)
    #[arg(long, value_name = "HZ", default_value_t = 10.0)]
    pub rate: f64,
    /// Link for the PowerCube modules (default: --link when it is CAN or sim)
    #[arg(long, value_name = "URI")]
    pub cube_link: Option<String>,
    /// Link for the PA-CONTROL (default: --link when it is sim)
    #[arg(long, value_name = "URI")]
    pub pac_link: Option<String>,
    /// Link for the Cdios node (default: --link when it is CAN or sim)
    #[arg(long, value_name = "URI")]
    pub cdios_link: Option<String>,
    /// PowerCube module addresses, e.g. 3,5,17 or 1-8 (default: scan 1 to 31 at start)
    #[arg(short = 'm', long = "module", alias = "modules", value_name = "LIST", value_parser = ids::list(POWERCUBE_MODULE))]
    pub modules: Option<IdList>,
    /// PA-CONTROL axes to show, e.g. 1,2 (default: as many as the controller has configured)
    #[arg(long = "axis", alias = "axes", value_name = "LIST", value_parser = ids::list(PAC_AXIS))]
    pub axes: Option<IdList>,
    /// Cdios node id
    #[arg(long, value_name = "N", default_value_t = CDIOS_FACTORY_NODE, value_parser = ids::id(CDIOS_NODE))]
    pub node: u8,
    /// Cdios 6168 module ids, e.g. 0,1 (default: scan 0 to 15 at start)
    #[arg(long = "cdios-module", alias = "cdios-modules", value_name = "LIST", value_parser = ids::list(CDIOS_MODULE))]
    pub cdios_modules: Option<IdList>,
    /// Directory the chart snapshots (key p) are written to, as axisctl-chart-DEVICE-UTCTIME.svg
    #[arg(long, value_name = "DIR", default_value = ".")]
    pub snapshot_dir: std::path::PathBuf,
    /// Leave out families: powercube, pac, cdios (repeatable)
    #[arg(long, value_name = "FAMILY", value_parser = parse_family)]
    pub without: Vec<Family>,
    /// Only these devices, of any family on any link of the bench (instead of -m, --axis, --node, --cdios-module): powercube:ID, pac, pac:AXIS, cdios:NODE/MODULE or bench-file names, comma-separated
    #[arg(short, long, value_name = "DEVICE[,DEVICE...]", value_delimiter = ',', num_args = 1, add = super::complete::bench_devices(None),
          conflicts_with_all = ["modules", "axes", "node", "cdios_modules", "without", "cube_link", "pac_link", "cdios_link"])]
    pub device: Vec<DeviceRef>,
}

/// A family by its registry name or alias.
pub fn parse_family(text: &str) -> Result<Family, String> {
    text.parse().map_err(|e: axisctl::family::UnknownFamily| e.to_string())
}
