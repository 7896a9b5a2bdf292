//! The PowerCube modules' source of the dashboard.

use axisctl::open::{OpenedLink, Opener};
use axisctl::proto::powercube::ModuleId;
use axisctl::tui::powercube::CubeSource;
use axisctl::tui::source::DeviceSource;

use crate::commands::dashboard::Setup;

/// The modules of `-m` (default: the ones that answer), on a CAN or RS232 link.
pub fn source(setup: &Setup, opener: &Opener, link: OpenedLink) -> Box<dyn DeviceSource> {
    let modules = setup.modules.as_ref().map(|l| l.to(ModuleId::new));
    Box::new(CubeSource::new(opener.powercube_on(link, &setup.opts), modules))
}
