//! Synchronized ramps (manual 7.2, CONFIGID_MOD_SYNC_MOTION): each module
//! in sync mode takes its target and holds it, then one StartMotion
//! broadcast starts them all at once. Every check of every module comes
//! before the first frame that changes anything; a module that would start
//! on its own target (sync mode off) is refused, as is a serial link (the
//! manual: "Valid only for CAN-Bus").

use super::moves::Wire;
use super::{Cubes, Error, Goal, Move, Moved, WaitEnd, WaitSpec};
use crate::proto::powercube::can::Broadcast;
use crate::proto::powercube::flags::config;
use crate::proto::powercube::table::ids;
use crate::proto::powercube::ModuleId;

/// A ramp of several modules to their own targets, started together.
#[derive(Debug, Clone, PartialEq)]
pub struct SyncRamp {
    /// In the order given; each module once.
    pub targets: Vec<(ModuleId, f64)>,
    pub vel: Option<f64>,
    pub acc: Option<f64>,
    pub ticks: bool,
}

impl SyncRamp {
    /// One position per module, in the same order; each module once.
    pub fn new(
        modules: &[ModuleId],
        positions: &[f64],
        vel: Option<f64>,
        acc: Option<f64>,
        ticks: bool,
    ) -> Result<Self, Error> {
        if modules.len() != positions.len() {
            return Err(Error::Refused(format!(
                "{} modules and {} positions: give one position per module, in the same order; nothing was sent",
                modules.len(),
                positions.len()
            )));
        }
        if let Some(m) = modules.iter().enumerate().find_map(|(i, m)| modules[..i].contains(m).then_some(m)) {
            return Err(Error::Refused(format!("module {m} is listed twice; nothing was sent")));
        }
        let s = Self { targets: modules.iter().copied().zip(positions.iter().copied()).collect(), vel, acc, ticks };
        s.check()?;
        Ok(s)
    }

    fn ramp(&self, pos: f64) -> Move {
        Move::Ramp { pos, vel: self.vel, acc: self.acc }
    }

    /// The checks that need no module (values finite and representable).
    pub fn check(&self) -> Result<(), Error> {
        self.targets.iter().try_for_each(|(_, pos)| self.ramp(*pos).check(self.ticks))
    }
}

/// Targets every module of a [`SyncRamp`] took and holds until
/// [`Cubes::start_sync`].
#[must_use = "the modules hold their targets until the start broadcast"]
#[derive(Debug)]
pub struct Loaded {
    pub moved: Vec<(ModuleId, Moved)>,
}

impl Cubes {
    /// Checks every module (CAN link, sync mode, ready, limits unless
    /// `force`), then gives each its target. If a target is not taken (or
    /// its acknowledge is lost), the modules given one so far (and that one)
    /// are halted, each up to `halt_attempts` times, which drops what they
    /// hold: no later broadcast may start half a synchronized move.
    pub fn load_sync(&mut self, s: &SyncRamp, force: bool, halt_attempts: u32) -> Result<Loaded, Error> {
        self.load_sync_armed(s, force, halt_attempts, false)
    }

    /// [`Self::load_sync`]; with `supervised`, the dead-man backstop is
    /// armed between the checks and the first target.
    fn load_sync_armed(
        &mut self,
        s: &SyncRamp,
        force: bool,
        halt_attempts: u32,
        supervised: bool,
    ) -> Result<Loaded, Error> {
        s.check()?;
        if !self.session().is_can() {
            return Err(Error::Refused(
                "synchronized motion is a CAN feature (the manual: CONFIGID_MOD_SYNC_MOTION is valid only for \
                 CAN-Bus); nothing was sent"
                    .into(),
            ));
        }
        let mut wires: Vec<(ModuleId, Move, Wire)> = Vec::new();
        let mut configs = Vec::new();
        for &(m, pos) in &s.targets {
            let word = self.get_u32(m, ids::CONFIG)?;
            if word & config::SYNC_MOTION == 0 {
                return Err(Error::NotSyncMode { module: m });
            }
            configs.push((m, Some(word)));
            let mv = s.ramp(pos);
            let wire = self.checked(m, mv, s.ticks, force)?;
            wires.push((m, mv, wire));
        }
        if supervised {
            self.arm_deadman(&configs)?;
        }
        let mut moved = Vec::new();
        for (m, mv, wire) in wires {
            match self.send_move(m, mv, s.ticks, wire, &|| false) {
                Ok(done) => moved.push((m, done)),
                Err(e) => {
                    let loaded: Vec<ModuleId> = moved.iter().map(|(m, _)| *m).chain([m]).collect();
                    let halted = self.halt_each(&loaded, halt_attempts);
                    return Err(Error::SyncAborted { module: m, halted, source: Box::new(e) });
                }
            }
        }
        Ok(Loaded { moved })
    }

    /// The one StartMotion broadcast that starts every loaded module.
    pub fn start_sync(&mut self, loaded: Loaded) -> Result<Vec<(ModuleId, Moved)>, Error> {
        self.session().broadcast(Broadcast::StartMotion)?;
        Ok(loaded.moved)
    }

    /// [`Self::load_sync`], then [`Self::start_sync`] unless `interrupted`
    /// by then: the modules hold their targets until the start broadcast,
    /// so a signal during the load moves nothing; they are halted (which
    /// drops what they hold) and no start broadcast goes out.
    pub fn move_sync_supervised(
        &mut self,
        s: &SyncRamp,
        force: bool,
        halt_attempts: u32,
        interrupted: &dyn Fn() -> bool,
    ) -> Result<Vec<(ModuleId, Moved)>, Error> {
        let loaded = self.load_sync_armed(s, force, halt_attempts, true)?;
        if interrupted() {
            let modules: Vec<ModuleId> = loaded.moved.iter().map(|(m, _)| *m).collect();
            let halted = self.halt_each(&modules, halt_attempts);
            return Err(Error::InterruptedBefore { what: "the StartMotion broadcast".into(), halted });
        }
        self.start_sync(loaded)
    }

    /// [`Self::load_sync`], then [`Self::start_sync`].
    pub fn move_sync(
        &mut self,
        s: &SyncRamp,
        force: bool,
        halt_attempts: u32,
    ) -> Result<Vec<(ModuleId, Moved)>, Error> {
        let loaded = self.load_sync(s, force, halt_attempts)?;
        self.start_sync(loaded)
    }
}

impl Cubes {
    /// Waits for the end of every ramp of a started synchronized move, as
    /// [`Self::wait_each`] does.
    pub fn wait_sync(
        &mut self,
        started: &[(ModuleId, Moved)],
        ticks: bool,
        spec: WaitSpec,
        interrupted: &dyn Fn() -> bool,
        progress: &mut dyn FnMut(ModuleId, f32, u32),
    ) -> Result<Vec<WaitEnd>, Error> {
        let goals: Vec<(ModuleId, Goal)> = started
            .iter()
            .map(|(m, moved)| (*m, Goal::RampEnd { target: moved.target.unwrap_or(f64::NAN), ticks }))
            .collect();
        self.wait_each(&goals, spec, interrupted, progress)
    }

    /// Waits for each module's goal, one module after the other: the
    /// modules of one motion (a synchronized move, a Home to all). When one
    /// wait fails (fault, lost module, timeout, interruption), that module
    /// is halted by its wait, and every other module of the motion is halted
    /// before the error is returned, which says so: the motion is one.
    pub fn wait_each(
        &mut self,
        goals: &[(ModuleId, Goal)],
        spec: WaitSpec,
        interrupted: &dyn Fn() -> bool,
        progress: &mut dyn FnMut(ModuleId, f32, u32),
    ) -> Result<Vec<WaitEnd>, Error> {
        let mut ends = Vec::new();
        let mut since_start = std::time::Duration::ZERO;
        for &(m, goal) in goals {
            match self.wait(m, goal, spec, interrupted, &mut |p, c| progress(m, p, c)) {
                Ok(mut end) => {
                    // The modules move together but are waited for one after
                    // the other: each one's time counts from the start of the
                    // motion, not from the end of the previous wait.
                    since_start += end.elapsed;
                    end.elapsed = since_start;
                    ends.push(end);
                }
                Err(e) => {
                    let others: Vec<ModuleId> = goals.iter().map(|(o, _)| *o).filter(|o| *o != m).collect();
                    if others.is_empty() {
                        return Err(e);
                    }
                    let halted = self.halt_each(&others, spec.halt_attempts);
                    return Err(Error::OthersHalted { source: Box::new(e), halted });
                }
            }
        }
        Ok(ends)
    }
}
