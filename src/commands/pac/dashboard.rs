//! The PA-CONTROL's source of the dashboard.

use axisctl::open::{OpenedLink, Opener};
use axisctl::tui::pac::PacSource;
use axisctl::tui::source::DeviceSource;

use crate::commands::dashboard::Setup;

/// The controller and the axes of `--axis` (default: as many as it has
/// configured), on its serial line.
pub fn source(setup: &Setup, opener: &Opener, link: OpenedLink) -> Box<dyn DeviceSource> {
    match link {
        OpenedLink::Serial(line) => {
            Box::new(PacSource::new(opener.pac_on(line, &setup.opts), setup.axes.as_ref().map(|l| l.0.clone())))
        }
        OpenedLink::Can(_) => unreachable!("assign checked that the link fits the PA-CONTROL"),
    }
}
