//! The Cdios device face: one face per node, for its 6168 modules.

use crate::device::face::{Face, FaceError, Found, Halt, HaltStep, Manner, MotionTarget, State, StopHow};
use crate::family::Family;
use crate::proto::cdios::{ModuleId, StopOption};

use super::{Node, Stopped};

impl Node {
    fn module_here(&self, at: MotionTarget) -> Result<ModuleId, FaceError> {
        match at {
            MotionTarget::Cdios { node, module } if node == self.id() => Ok(module),
            other => Err(FaceError::NotHere(other, "Cdios node")),
        }
    }
}

fn said(s: Stopped) -> Halt {
    match s {
        Stopped::FastStop { confirmed } => Halt::FastStop { confirmed },
        Stopped::NotRunning => Halt::AtRest,
    }
}

impl Face for Node {
    fn family(&self) -> Family {
        Family::Cdios
    }

    /// A node that does not wake is absent (no device, no error).
    fn discover(&mut self, _candidates: &[u8]) -> Result<Vec<Found>, FaceError> {
        let Ok(modules) = self.scan() else { return Ok(Vec::new()) };
        let node = self.id();
        Ok(modules
            .into_iter()
            .map(|module| Found { target: MotionTarget::Cdios { node, module }, detail: String::new() })
            .collect())
    }

    fn identify(&mut self, at: MotionTarget) -> Result<String, FaceError> {
        let m = self.module_here(at)?;
        let slots = Node::identify(self)?;
        Ok(match slots.iter().find(|s| s.module == m.get()) {
            Some(s) => format!("type {} version {}", s.ty, s.version),
            None => "no module in this slot".into(),
        })
    }

    fn state(&mut self, at: MotionTarget) -> Result<State, FaceError> {
        let m = self.module_here(at)?;
        let moving = self.running(m)?;
        Ok(State { moving, detail: if moving { "running" } else { "at rest" }.into() })
    }

    /// The fast stop, resent when unconfirmed; a motor that came to rest by
    /// itself refuses it, which is the state asked for.
    fn halt(&mut self, at: MotionTarget, attempts: u32) -> Result<Halt, FaceError> {
        let m = self.module_here(at)?;
        Ok(match self.halt_motor(m, attempts)? {
            true => Halt::FastStop { confirmed: true },
            false => Halt::AtRest,
        })
    }

    fn stop(&mut self, at: MotionTarget) -> Result<Halt, FaceError> {
        self.stop_with(at, StopHow::default())
    }

    /// 25h with the stop option of `how` (the face's default: the fast
    /// stop); a motor at rest is [`Halt::AtRest`]. Whichever option,
    /// a sent stop is told as [`Halt::FastStop`] with its confirmation.
    fn stop_with(&mut self, at: MotionTarget, how: StopHow) -> Result<Halt, FaceError> {
        let m = self.module_here(at)?;
        if how.at_standstill {
            return Err(FaceError::Unsupported(format!("the Cdios has no {how}")));
        }
        let option = match how.manner {
            Manner::Default | Manner::Fast => StopOption::FastStop,
            Manner::Decelerate => StopOption::DecelerateAndStop,
            Manner::DecelerateToMinimum => StopOption::DecelerateToMinimum,
        };
        Ok(said(Node::stop(self, m, option, how.on_sync)?))
    }

    /// A fast stop to each module (known, or else every one the node's
    /// scan finds; a scan that fails is one failed step).
    fn halt_all(&mut self, known: Option<&[MotionTarget]>) -> Vec<HaltStep> {
        let modules: Vec<ModuleId> = match known {
            Some(known) => known.iter().filter_map(|t| self.module_here(*t).ok()).collect(),
            None => match self.scan() {
                Ok(m) => m,
                Err(e) => return vec![HaltStep { target: None, result: Err(e.into()) }],
            },
        };
        let node = self.id();
        Node::halt_all(self, &modules)
            .into_iter()
            .map(|(module, r)| HaltStep {
                target: Some(MotionTarget::Cdios { node, module }),
                result: r.map(said).map_err(Into::into),
            })
            .collect()
    }
}
