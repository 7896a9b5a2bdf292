//! When the motion a recording started is halted, and by which sequence.
//!
//! A recording that reached its `--count` or `--for` leaves a motion that
//! already ended alone, but halts one that still moves: nobody watches it
//! from then on. A recording that ended any other way halts the motion
//! whatever it does: a signal, an output that cannot be written, a panic
//! on another thread (all of which end it as [`End::Stopped`]) or a failed
//! read (the device's state is then unknown). The halt sequences are the
//! device layer's, the ones the supervised waits use.

use super::{Address, CdiosSampler, CubeSampler, End, PacSampler, RecordError, Sampler};
use crate::proto::cdios::ModuleId as CdiosModule;
use crate::proto::powercube::flags::state;
use crate::proto::powercube::table::ids;
use crate::proto::powercube::ModuleId;

/// When the recorded motion is halted at the end of the recording.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum HaltWhen {
    /// Only if the device still moves (or cannot be read).
    IfMoving,
    /// Whatever the device does.
    Always,
}

impl HaltWhen {
    /// How the recording ended decides: only the end it was asked for
    /// (`--count`, `--for`) may leave the device alone.
    pub fn after(ended: &Result<End, RecordError>) -> Self {
        match ended {
            Ok(End::Done) => Self::IfMoving,
            Ok(End::Stopped) | Err(_) => Self::Always,
        }
    }
}

/// A sampler whose device a recorded motion moves: the look at the device
/// and its halt, on the sampler's own link.
pub trait HaltMotion: Sampler {
    /// Whether the device at `at` still moves; `None` when that cannot be
    /// read (it is then halted).
    fn still_moving(&mut self, at: Address) -> Option<bool>;

    /// The family's halt of `at`: what was done (`halted`), or the failure
    /// in capitals (`HALT FAILED: ...`). `attempts`: how often a halt whose
    /// acknowledge is lost is sent.
    fn halt(&mut self, at: Address, attempts: u32) -> Result<String, String>;

    /// After the halt: what the family set up to supervise the motion is
    /// undone (a PowerCube's dead-man backstop); the failure, said.
    fn release(&mut self) -> Result<(), String> {
        Ok(())
    }
}

/// Halts the motion at `at` when `when` says so; what was done, `None` when
/// the device stood and was left alone.
pub fn halt_motion<S: HaltMotion + ?Sized>(
    s: &mut S,
    at: Address,
    when: HaltWhen,
    attempts: u32,
) -> Option<Result<String, String>> {
    if when == HaltWhen::IfMoving && s.still_moving(at) == Some(false) {
        return None;
    }
    Some(s.halt(at, attempts))
}

/// A motion address of another family than the sampler's: the binary
/// pairs them before the link opens, so this never holds a device.
fn foreign(at: Address) -> String {
    format!("HALT FAILED: {} is not a device of this recording", at.label())
}

impl HaltMotion for CubeSampler {
    fn still_moving(&mut self, at: Address) -> Option<bool> {
        let Address::Module(m) = at else { return None };
        let m = ModuleId::new(m)?;
        self.cubes().get_u32(m, ids::CUBE_STATE).ok().map(|word| word & state::MOTION != 0)
    }

    fn halt(&mut self, at: Address, attempts: u32) -> Result<String, String> {
        let Some(m) = (match at {
            Address::Module(m) => ModuleId::new(m),
            _ => None,
        }) else {
            return Err(foreign(at));
        };
        match self.cubes().halt_retrying(m, attempts) {
            Ok(()) => Ok("halted".into()),
            Err(e) => Err(format!("HALT FAILED: {e}")),
        }
    }

    fn release(&mut self) -> Result<(), String> {
        self.cubes().release_deadman().map_err(|e| e.to_string())
    }
}

impl HaltMotion for PacSampler {
    fn still_moving(&mut self, at: Address) -> Option<bool> {
        let Address::Axis(axis) = at else { return None };
        let ctl = self.controller();
        // A command still running (BE = 0) moves, whatever the axis says.
        if ctl.busy().is_some() {
            return Some(true);
        }
        // 1910 axis status 1: moving.
        ctl.read_i64(0x1910, i64::from(axis)).ok().map(|status| status == 1)
    }

    /// 0A93, polled to standstill: the stop of last resort the waits use.
    fn halt(&mut self, at: Address, _attempts: u32) -> Result<String, String> {
        let Address::Axis(axis) = at else { return Err(foreign(at)) };
        match self.controller().halt_axis(axis).result {
            Ok(position) => Ok(format!("stopped at {position}")),
            Err(e) => Err(format!("STOP FAILED: {e}")),
        }
    }
}

impl HaltMotion for CdiosSampler {
    fn still_moving(&mut self, at: Address) -> Option<bool> {
        let Address::CdiosModule { module, .. } = at else { return None };
        self.node().running(CdiosModule::new(module)?).ok()
    }

    fn halt(&mut self, at: Address, attempts: u32) -> Result<String, String> {
        let Some(m) = (match at {
            Address::CdiosModule { module, .. } => CdiosModule::new(module),
            _ => None,
        }) else {
            return Err(foreign(at));
        };
        match self.node().halt_motor(m, attempts) {
            Ok(true) => Ok("fast stop sent".into()),
            Ok(false) => Ok("not running (it had come to rest)".into()),
            Err(e) => Err(format!("STOP FAILED: {e}")),
        }
    }
}

#[cfg(test)]
mod tests;
