//! Moves, checked before anything is sent: the value must be finite and fit
//! the motion's wire type, the module must be ready, and (unless forced)
//! the value must be within the module's own limits as read from it.

use super::{param, Cubes, Error};
use crate::device::supervisor;
use crate::proto::powercube::flags::config;
use crate::proto::powercube::frame::Value;
use crate::proto::powercube::limits::{self, Limits};
use crate::proto::powercube::table::ids;
use crate::proto::powercube::{ModuleId, Motion, MotionValue, Request};

/// One motion command; positions, velocities and accelerations are in units
/// or, with `ticks`, encoder ticks.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Move {
    /// FRAMP_MODE (IRAMP_MODE in ticks): a ramp to `pos`, with the target
    /// velocity and acceleration set first when given.
    Ramp { pos: f64, vel: Option<f64>, acc: Option<f64> },
    /// FSTEP_MODE: a step to `pos` in `time_ms`.
    Step { pos: f64, time_ms: u16 },
    /// FVEL_MODE: a constant velocity.
    Vel(f64),
    /// FCUR_MODE: a constant current in A (never in ticks).
    Cur(f64),
}

/// Where a ramp or step goes: to a position, or by a distance from where
/// the module is (`--relative`, the dashboard's jog keys).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Target {
    To(f64),
    By(f64),
}

/// A move that was acknowledged.
#[derive(Debug, Clone, PartialEq)]
pub struct Moved {
    /// The motion command as the trace names it, e.g. `SetMotion FRAMP_MODE 0.75`.
    pub described: String,
    /// The position the ramp or step goes to (units or ticks).
    pub target: Option<f64>,
}

/// The wire values of a move that passed the checks that need no module.
pub(super) struct Wire {
    value: MotionValue,
    vel: Option<MotionValue>,
    acc: Option<MotionValue>,
}

impl Move {
    /// The checks that need no module: finite, representable in the
    /// motion's wire type, ramp velocity and acceleration positive.
    pub fn check(&self, ticks: bool) -> Result<(), Error> {
        self.wire(ticks).map(|_| ())
    }

    fn wire(&self, ticks: bool) -> Result<Wire, Error> {
        let mv = |v: f64, what| limits::motion_value(v, ticks, what);
        Ok(match *self {
            Self::Ramp { pos, vel, acc } => {
                let value = mv(pos, "target position")?;
                let vel_v = vel.map(|v| mv(v, "velocity")).transpose()?;
                let acc_v = acc.map(|a| mv(a, "acceleration")).transpose()?;
                for (name, v) in [("velocity", vel), ("acceleration", acc)] {
                    if let Some(v) = v {
                        limits::check_positive(name, v)?;
                    }
                }
                Wire { value, vel: vel_v, acc: acc_v }
            }
            Self::Step { pos, time_ms } => {
                // A step in no time is a jump the module cannot make.
                limits::check_positive("step time (ms)", f64::from(time_ms))?;
                Wire { value: mv(pos, "target position")?, vel: None, acc: None }
            }
            Self::Vel(v) => Wire { value: mv(v, "velocity")?, vel: None, acc: None },
            Self::Cur(a) => Wire { value: MotionValue::Float(limits::float32("current", a)?), vel: None, acc: None },
        })
    }

    /// The limits a move is checked against are read in ticks only for the
    /// tick motions; current has no tick form.
    fn ticks(&self, ticks: bool) -> bool {
        ticks && !matches!(self, Self::Cur(_))
    }

    /// A ramp to `pos` checked as `move-ramp` checks it, against limits
    /// already read (the dashboard's target prompt, before its worker checks
    /// again against fresh ones).
    pub fn check_ramp_target(l: &Limits, m: ModuleId, pos: f64) -> Result<(), Error> {
        let ramp = Self::Ramp { pos, vel: None, acc: None };
        ramp.check(l.ticks)?;
        ramp.within(l, m)
    }

    fn within(&self, l: &Limits, m: ModuleId) -> Result<(), Error> {
        match *self {
            Self::Ramp { pos, vel, acc } => {
                l.check_pos(pos, m)?;
                if let Some(v) = vel {
                    l.check_vel(v, m)?;
                }
                if let Some(a) = acc {
                    l.check_acc(a, m)?;
                }
            }
            Self::Step { pos, .. } => l.check_pos(pos, m)?,
            Self::Vel(v) => l.check_vel(v, m)?,
            Self::Cur(a) => l.check_cur(a, m)?,
        }
        Ok(())
    }

    /// The motion id of the manual's motion table.
    fn motion_id(&self, ticks: bool) -> u8 {
        match (self, ticks) {
            (Self::Ramp { .. }, false) => 4,
            (Self::Ramp { .. }, true) => 9,
            (Self::Step { .. }, false) => 6,
            (Self::Step { .. }, true) => 11,
            (Self::Vel(_), false) => 7,
            (Self::Vel(_), true) => 12,
            (Self::Cur(_), _) => 8,
        }
    }

    fn target(&self) -> Option<f64> {
        match *self {
            Self::Ramp { pos, .. } | Self::Step { pos, .. } => Some(pos),
            Self::Vel(_) | Self::Cur(_) => None,
        }
    }
}

fn value_of(v: MotionValue) -> Value {
    match v {
        MotionValue::Float(f) => Value::Float(f),
        MotionValue::Int32(i) => Value::Int32(i),
        MotionValue::Int16(i) => Value::Int16(i),
    }
}

impl Cubes {
    /// Checks a move and sends it: wire type, then readiness (the state is
    /// read), then the module's limits (read from it) unless `force`. A
    /// refusal sends no motion command; the motion is never sent twice.
    pub fn move_module(&mut self, m: ModuleId, mv: Move, ticks: bool, force: bool) -> Result<Moved, Error> {
        let wire = self.checked(m, mv, ticks, force)?;
        self.send_move(m, mv, ticks, wire, &|| false)
    }

    /// [`Self::move_module`] for a caller that waits for the end of the
    /// motion: a module in sync mode would hold it until a start broadcast
    /// nobody sends, so it is refused before anything is sent.
    pub fn move_to_wait_for(&mut self, m: ModuleId, mv: Move, ticks: bool, force: bool) -> Result<Moved, Error> {
        self.ensure_starts_alone(m)?;
        self.move_module(m, mv, ticks, force)
    }

    /// [`Self::move_to_wait_for`] under supervision: a motion that went
    /// out without its acknowledge may still have been taken, so the module
    /// is halted (up to `halt_attempts` times) before the error is returned.
    pub fn move_supervised(
        &mut self,
        m: ModuleId,
        mv: Move,
        ticks: bool,
        force: bool,
        halt_attempts: u32,
    ) -> Result<Moved, Error> {
        let config_word = self.starting_config(m)?;
        let wire = self.checked(m, mv, ticks, force)?;
        self.arm_deadman(&[(m, config_word)])?;
        match self.send_move(m, mv, ticks, wire, &supervisor::stop_requested) {
            Err(Error::Motion { what, module, source }) => {
                let halt_failed = self.halt_retrying(module, halt_attempts).err().map(|e| e.to_string());
                Err(Error::MotionUnconfirmed { what, module, halt_failed, source })
            }
            other => other,
        }
    }

    /// Refuses a module that holds motion commands for the start broadcast
    /// (CONFIGID_MOD_SYNC_MOTION; the manual: valid only for CAN-Bus).
    pub fn ensure_starts_alone(&mut self, m: ModuleId) -> Result<(), Error> {
        self.starting_config(m).map(|_| ())
    }

    /// [`Self::ensure_starts_alone`], with the Config word it read (CAN
    /// only: `None` on RS232, where nothing is read).
    fn starting_config(&mut self, m: ModuleId) -> Result<Option<u32>, Error> {
        if !self.session().is_can() {
            return Ok(None);
        }
        let word = self.get_u32(m, ids::CONFIG)?;
        if word & config::SYNC_MOTION != 0 {
            return Err(Error::SyncMode { module: m });
        }
        Ok(Some(word))
    }

    /// Every check of [`Self::move_module`], nothing sent but reads.
    pub(super) fn checked(&mut self, m: ModuleId, mv: Move, ticks: bool, force: bool) -> Result<Wire, Error> {
        let ticks = mv.ticks(ticks);
        let wire = mv.wire(ticks)?;
        self.ensure_ready(m)?;
        if !force {
            let l = self.limits(m, ticks)?;
            mv.within(&l, m)?;
        }
        Ok(wire)
    }

    /// Sends a checked move: TargetVel / TargetAcc when given, then the
    /// motion command, once, unless `stop` has become true by then.
    pub(super) fn send_move(
        &mut self,
        m: ModuleId,
        mv: Move,
        ticks: bool,
        wire: Wire,
        stop: &dyn Fn() -> bool,
    ) -> Result<Moved, Error> {
        let ticks = mv.ticks(ticks);
        let (vel_id, acc_id) =
            if ticks { (ids::TARGET_VEL_INC, ids::TARGET_ACC_INC) } else { (ids::TARGET_VEL, ids::TARGET_ACC) };
        for (id, v) in [(vel_id, wire.vel), (acc_id, wire.acc)] {
            if let Some(v) = v {
                self.set_param(m, param(id), value_of(v))?;
            }
        }
        let time_ms = match mv {
            Move::Step { time_ms, .. } => Some(time_ms),
            _ => None,
        };
        let req = Request::SetMotion(Motion { id: mv.motion_id(ticks), value: wire.value, time_ms });
        let described = req.to_string();
        // The checks and the target writes are exchanges: a signal that came
        // meanwhile means the motion is not sent at all, rather than sent
        // and halted.
        if stop() {
            return Err(Error::InterruptedBefore { what: format!("the motion of module {m}"), halted: Vec::new() });
        }
        match self.session().transact(m, &req) {
            Ok(_) => Ok(Moved { described, target: mv.target() }),
            Err(source) => Err(Error::Motion { what: described, module: m, source }),
        }
    }

    /// Where `target` lies, in units or with `ticks` in encoder ticks: a
    /// step is added to where the module is now (ActPos or ActIPos), read
    /// before anything moves, so a failed read sends no motion.
    pub fn resolve(&mut self, m: ModuleId, target: Target, ticks: bool) -> Result<f64, Error> {
        match target {
            Target::To(p) => Ok(p),
            Target::By(step) => {
                limits::check_finite("relative distance", step)?;
                Ok(self.read_now(m, &[if ticks { ids::ACT_I_POS } else { ids::ACT_POS }])?[0] + step)
            }
        }
    }

    /// A ramp in units with the module's current velocity and acceleration,
    /// to a position or by a step from ActPos: checked like
    /// [`Self::move_module`]. Returns the target position. A module in sync
    /// mode is refused: a key press that moves nothing until someone's
    /// broadcast would start it later, unexpected.
    pub fn ramp(&mut self, m: ModuleId, target: Target) -> Result<f64, Error> {
        let pos = self.resolve(m, target, false)?;
        let mv = Move::Ramp { pos, vel: None, acc: None };
        mv.check(false)?;
        self.ensure_starts_alone(m)?;
        self.move_module(m, mv, false, false)?;
        Ok(pos)
    }
}
