//! `axisctl dashboard` options, as typed.

use clap::Args;

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
    /// PowerCube module ids, e.g. 3,5,17 or 1-8 (default: scan 1..31 at start)
    #[arg(long, value_name = "LIST")]
    pub modules: Option<String>,
    /// PA-CONTROL axes to show, e.g. 1,2 (default: as many as the controller has configured)
    #[arg(long, value_name = "LIST")]
    pub axes: Option<String>,
    /// Cdios node id
    #[arg(long, value_name = "N", default_value_t = 1, value_parser = clap::value_parser!(u8).range(1..=127))]
    pub node: u8,
    /// Cdios 6168 module ids, e.g. 0,1 (default: scan 0..15 at start)
    #[arg(long, value_name = "LIST")]
    pub cdios_modules: Option<String>,
    /// Leave out families: powercube, pac, cdios (repeatable)
    #[arg(long, value_name = "FAMILY")]
    pub without: Vec<String>,
}
