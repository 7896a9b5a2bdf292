//! The PowerCube's device face: one face for the modules of a bus.

use crate::device::face::{Face, FaceError, Found, Halt, HaltStep, MotionTarget, State};
use crate::family::Family;
use crate::proto::powercube::flags::state;
use crate::proto::powercube::ModuleId;

use super::{version_text, Cubes, Simple};

fn here(at: MotionTarget) -> Result<ModuleId, FaceError> {
    match at {
        MotionTarget::Cube(m) => Ok(m),
        other => Err(FaceError::NotHere(other, "PowerCube module")),
    }
}

impl Face for Cubes {
    fn family(&self) -> Family {
        Family::PowerCube
    }

    /// A module that does not answer in time is absent; any other failure
    /// ends the scan with its error.
    fn discover(&mut self, candidates: &[u8]) -> Result<Vec<Found>, FaceError> {
        let ids: Vec<ModuleId> = if candidates.is_empty() {
            ModuleId::all().collect()
        } else {
            candidates.iter().filter_map(|m| ModuleId::new(*m)).collect()
        };
        Ok(self
            .scan(&ids)?
            .into_iter()
            .map(|f| {
                let version = f.version.as_f64().unwrap_or(f64::NAN) as u16;
                Found { target: MotionTarget::Cube(f.module), detail: format!("version {}", version_text(version)) }
            })
            .collect())
    }

    fn identify(&mut self, at: MotionTarget) -> Result<String, FaceError> {
        Ok(format!("version {}", version_text(self.version(here(at)?)?)))
    }

    fn state(&mut self, at: MotionTarget) -> Result<State, FaceError> {
        let word = Cubes::state(self, here(at)?)?;
        Ok(State { moving: word & state::MOTION != 0, detail: format!("CubeState 0x{word:08X}") })
    }

    /// One module: its Halt, acknowledged, resent when the acknowledge is
    /// lost. The bus: the broadcast, which stops every module known or not.
    fn halt(&mut self, at: MotionTarget, attempts: u32) -> Result<Halt, FaceError> {
        match at {
            MotionTarget::CubeBus => self.simple(None, Simple::Halt).map(|()| Halt::Broadcast).map_err(Into::into),
            at => Ok(self.halt_retrying(here(at)?, attempts).map(|()| Halt::Halted)?),
        }
    }

    /// The PowerCube has one stop, Halt; a module at rest takes it too.
    fn stop(&mut self, at: MotionTarget) -> Result<Halt, FaceError> {
        self.halt(at, 1)
    }

    /// The broadcast first (one frame, no answer needed), then each module
    /// (known, or else every one that answers a probe of the whole id
    /// range) gets its acknowledged Halt: a lost broadcast is seen.
    fn halt_all(&mut self, known: Option<&[MotionTarget]>) -> Vec<HaltStep> {
        let broadcast = self.simple(None, Simple::Halt).map(|()| Halt::Broadcast).map_err(Into::into);
        let mut steps = vec![HaltStep { target: None, result: broadcast }];
        let modules: Vec<ModuleId> = match known {
            Some(known) => known.iter().filter_map(|t| here(*t).ok()).collect(),
            None => match self.scan(&ModuleId::all().collect::<Vec<_>>()) {
                Ok(found) => found.into_iter().map(|f| f.module).collect(),
                Err(e) => {
                    steps.push(HaltStep { target: None, result: Err(e.into()) });
                    Vec::new()
                }
            },
        };
        for m in modules {
            let r = self.simple(Some(m), Simple::Halt).map(|()| Halt::Halted).map_err(Into::into);
            steps.push(HaltStep { target: Some(MotionTarget::Cube(m)), result: r });
        }
        steps
    }
}
