//! The PA-CONTROL device source: the controller (operating status, error
//! number) and its axes (position, speed, 1910 status, 1921 extended
//! status), over one half-duplex RS232 line. Every operation and its checks
//! are [`device::pac`](crate::device::pac)'s; this only turns them into
//! snapshots and event texts.
//!
//! While a reference drive runs the controller takes only polls, so the
//! controller line polls it and the axes show as stale with that reason.

use super::source::{Action, DeviceSource, HaltReport, Snapshot, SourceError};
use super::ui::pac::{PacAxisSnap, PacCtrlSnap};
use crate::address::Address;
use crate::device::face::Face;
use crate::device::pac::{Controller, Error};
use crate::family::Family;
use crate::session::pac::Pac;

pub struct PacSource {
    ctl: Controller,
    /// Given with `--axes`; `None` asks the controller.
    wanted: Option<Vec<u8>>,
}

impl From<Error> for SourceError {
    fn from(e: Error) -> Self {
        err(e)
    }
}

fn err(e: Error) -> SourceError {
    match e {
        Error::Session(s) => SourceError::Session(s),
        other => SourceError::Refused(other.to_string()),
    }
}

impl PacSource {
    pub fn new(pac: Pac, axes: Option<Vec<u8>>) -> Self {
        Self { ctl: Controller::new(pac), wanted: axes }
    }

    fn done(code: u16, done: crate::session::pac::Done) -> String {
        format!("{code:04X} done (status {})", done.ack.status)
    }
}

impl DeviceSource for PacSource {
    fn family(&self) -> Family {
        Family::Pac
    }

    fn discover(&mut self) -> Result<Vec<Address>, SourceError> {
        let axes = match self.wanted.clone() {
            Some(list) => list,
            None => (1..=self.ctl.configured_axes().map_err(err)?).collect(),
        };
        self.ctl.set_axes(axes);
        let mut out = vec![Address::Pac { axis: None }];
        out.extend(self.ctl.axes().iter().map(|a| Address::Pac { axis: Some(*a) }));
        Ok(out)
    }

    fn poll(&mut self, dev: Address) -> Result<Snapshot, SourceError> {
        match dev {
            Address::Pac { axis: None } => {
                let ack = self.ctl.poll_state().map_err(err)?;
                Ok(Snapshot::new(PacCtrlSnap {
                    status: ack.status,
                    error: ack.error,
                    axes: self.ctl.axes().len() as u8,
                }))
            }
            Address::Pac { axis: Some(axis) } => {
                if let Some(busy) = self.ctl.busy() {
                    return Err(SourceError::Refused(busy.to_string()));
                }
                let s = self.ctl.axis_state(axis).map_err(err)?;
                let area = self.ctl.traverse_area(axis).ok();
                Ok(Snapshot::new(PacAxisSnap {
                    position: s.position,
                    speed: s.speed,
                    status: s.status,
                    ext_status: s.ext_status,
                    min_pos: area.map(|a| a.min),
                    max_pos: area.map(|a| a.max),
                }))
            }
            other => Err(SourceError::Unsupported(format!("{} is not a PA-CONTROL device", other.label()))),
        }
    }

    fn act(&mut self, dev: Address, action: Action) -> Result<String, SourceError> {
        if action != Action::Halt {
            self.ctl.ensure_idle().map_err(|e| SourceError::Refused(format!("{e} (s or space stops it)")))?;
        }
        let ctl = &mut self.ctl;
        match (dev, action) {
            (_, Action::Online) => ctl.online().map(|d| Self::done(0x0603, d)),
            (_, Action::Offline) => ctl.offline().map(|d| Self::done(0x0A81, d)),
            (_, Action::Reset) => ctl.reset_error().and_then(|r| r.check()).map(|_| "error reset".into()),
            (Address::Pac { axis: None }, Action::Halt) => ctl.stop().map(|d| Self::done(0x0600, d)),
            (Address::Pac { axis: Some(axis) }, Action::Halt) => ctl.stop_axis(axis),
            (Address::Pac { axis: Some(axis) }, Action::Home) => ctl.start_reference(axis).map(|(_, done)| {
                if done {
                    "reference drive done".into()
                } else {
                    "reference drive started (only polls until it ends)".into()
                }
            }),
            (Address::Pac { axis: Some(axis) }, Action::Enable) => ctl.enable(axis).map(|d| Self::done(0x0A97, d)),
            (Address::Pac { axis: Some(axis) }, Action::Disable) => ctl.disable(axis).map(|d| Self::done(0x0A98, d)),
            (Address::Pac { axis: Some(axis) }, Action::Jog(d)) => {
                ctl.start_move(axis, d, true, true).map(|m| format!("moving to {}", m.target))
            }
            (Address::Pac { axis: Some(axis) }, Action::MoveTo(p)) => {
                ctl.start_move(axis, p, false, true).map(|m| format!("moving to {}", m.target))
            }
            (d, a) => return Err(SourceError::Unsupported(format!("{} has no {}", d.label(), a.name()))),
        }
        .map_err(err)
    }

    /// See [`Controller::halt_all`]: the mode is read fresh, automatic mode
    /// gets 0600, online mode 0A9A per axis.
    fn face(&mut self) -> &mut dyn Face {
        &mut self.ctl
    }

    fn halt_all(&mut self) -> Vec<HaltReport> {
        // The controller's axes were set at discovery: the face keeps them.
        super::source::halt_all(&mut self.ctl, &[])
    }
}
