//! The Cdios node's source of the dashboard.

use axisctl::open::{OpenedLink, Opener};
use axisctl::proto::cdios::{ModuleId, NodeId};
use axisctl::tui::cdios::CdiosSource;
use axisctl::tui::source::DeviceSource;

use crate::commands::dashboard::Setup;

/// The node of `--node` and its modules of `--cdios-module` (default: the
/// ones it reports), on a CAN link.
pub fn source(setup: &Setup, opener: &Opener, link: OpenedLink) -> Box<dyn DeviceSource> {
    match link {
        OpenedLink::Can(link) => Box::new(CdiosSource::new(
            opener.cdios_on(link, &setup.opts),
            NodeId::new(setup.node).expect("clap checks the node range"),
            setup.cdios_modules.as_ref().map(|l| l.to(ModuleId::new)),
            setup.retry,
        )),
        OpenedLink::Serial(_) => unreachable!("assign checked that the link fits the Cdios"),
    }
}
