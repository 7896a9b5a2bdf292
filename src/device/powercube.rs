//! PowerCube operations on the modules of one link: state and fault
//! interpretation, moves with their limit checks, halt / home / reset (one
//! module or the broadcast), halt-all, parameters, Config and DIO with
//! readback, the watchdog switch and the waits for the end of a motion.
//!
//! Every check that decides whether a frame may go out is made here, before
//! it goes out; the CLI and the dashboard only word the outcome.

mod deadman;
mod error;
mod face;
mod moves;
mod sync;
mod wait;

#[cfg(test)]
mod tests;

use std::collections::BTreeMap;

use crate::device::supervisor;
use crate::proto::powercube::can::Broadcast;
use crate::proto::powercube::flags::{self, config};
use crate::proto::powercube::frame::{parse_int, Value};
use crate::proto::powercube::limits::{self, Limits};
use crate::proto::powercube::table::{self, ids, ParamDef};
use crate::proto::powercube::{ModuleId, Request, Response};
use crate::session::powercube::{decode_get, PowerCube};
use crate::session::SessionError;

pub use crate::proto::powercube::table::version_text;
pub use deadman::{Deadman, REFRESH_EVERY};
pub use error::Error;
pub use moves::{Move, Moved, Target};
pub use sync::{Loaded, SyncRamp};
pub use wait::{homed, Goal, WaitEnd, WaitSpec};

/// The values that change while a module runs, as a dashboard poll and
/// `info` read them: position, velocity, current, temperature, supplies, state.
pub const LIVE: [u8; 7] = [
    ids::ACT_POS,
    ids::ACT_VEL,
    ids::CUR,
    ids::ACT_F_TEMP,
    ids::ACT_F_MOTOR_SUPPLY,
    ids::ACT_F_LOGIC_SUPPLY,
    ids::CUBE_STATE,
];

/// A parameter of the table by id; the `ids` constants are all in it.
pub fn param(id: u8) -> &'static ParamDef {
    table::param(id).expect("ids constants are in the table")
}

/// The commands that go to one module or, as a broadcast, to all.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Simple {
    Home,
    Reset,
    Halt,
}

impl Simple {
    pub fn request(self) -> Request {
        match self {
            Self::Home => Request::Home,
            Self::Reset => Request::Reset,
            Self::Halt => Request::Halt,
        }
    }

    pub fn broadcast(self) -> Broadcast {
        match self {
            Self::Home => Broadcast::Home,
            Self::Reset => Broadcast::Reset,
            Self::Halt => Broadcast::Halt,
        }
    }

    /// The manual's name of the command (`Home`, `Reset`, `Halt`).
    pub fn name(self) -> &'static str {
        self.request().command().name()
    }
}

/// The outcome of a halt-all: the broadcast, then each known module's
/// acknowledged Halt.
#[derive(Debug)]
pub struct HaltAll {
    pub broadcast: Result<(), Error>,
    pub modules: Vec<(ModuleId, Result<(), Error>)>,
}

/// What a scan probe found: a module and its DefCubeVersion.
#[derive(Debug, Clone, PartialEq)]
pub struct Found {
    pub module: ModuleId,
    pub version: Value,
}

/// A Config change: flags to set and clear, or a whole new word.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct ConfigChange {
    pub set: u32,
    pub clear: u32,
    pub raw: Option<u32>,
}

impl ConfigChange {
    /// `+FLAG` / `-FLAG` items and an optional raw word, all resolved before
    /// anything is sent.
    pub fn parse(changes: &[String], raw: Option<&str>) -> Result<Self, Error> {
        let mut out = Self::default();
        for c in changes {
            let (on, name) = match c.as_bytes().first() {
                Some(b'+') => (true, &c[1..]),
                Some(b'-') => (false, &c[1..]),
                _ => return Err(Error::Refused(format!("{c:?}: write +FLAG to set or -FLAG to clear"))),
            };
            let def = flags::CONFIG.flag(name).ok_or_else(|| {
                Error::Refused(format!(
                    "unknown Config flag {name:?} (e.g. CONFIGID_MOD_BRAKE_PRESENT or brake-present)"
                ))
            })?;
            if on {
                out.set |= def.mask
            } else {
                out.clear |= def.mask
            }
        }
        out.raw = raw
            .map(|r| {
                parse_int(r)
                    .and_then(|v| u32::try_from(v).ok())
                    .ok_or_else(|| Error::Refused(format!("--raw {r:?} is not a 32-bit value")))
            })
            .transpose()?;
        Ok(out)
    }
}

/// Config changes that take a protection away, and what each does; such a
/// change is sent only with `--force`.
const SAFETY_FLAGS: [(u32, bool, &str); 5] = [
    (
        config::DISABLE_ACK,
        true,
        "+disable-ack switches off every acknowledge but GetExtended's: a lost command, a motion included, goes unnoticed",
    ),
    (config::SW1_ENABLED, false, "-sw1-enabled switches limit switch 1 off: the module no longer stops at it"),
    (config::SW2_ENABLED, false, "-sw2-enabled switches limit switch 2 off: the module no longer stops at it"),
    (
        config::WATCHDOG_ENABLE,
        false,
        "-watchdog-enable takes the watchdog out of action: nothing halts the module when the host dies (`axisctl watchdog off` does this on purpose)",
    ),
    (
        config::WATCHDOG_ENABLE,
        true,
        "+watchdog-enable arms the watchdog without switching it online (`axisctl watchdog on` does both, in a state the tool can tell)",
    ),
];

impl ConfigChange {
    /// What the change does that removes a safety: the flags of
    /// [`SAFETY_FLAGS`] it sets or clears, or a whole word (`--raw`), which
    /// may carry any of them.
    pub fn removed_safeties(&self) -> Vec<&'static str> {
        if self.raw.is_some() {
            return vec!["--raw replaces the whole Config word, limit switch, acknowledge and watchdog flags included"];
        }
        SAFETY_FLAGS
            .iter()
            .filter(|(mask, on, _)| if *on { self.set & mask != 0 } else { self.clear & mask != 0 })
            .map(|(_, _, what)| *what)
            .collect()
    }

    /// Refuses a change that removes a safety unless `force`; nothing is sent.
    pub fn check_safeties(&self, force: bool) -> Result<(), Error> {
        let removed = self.removed_safeties();
        if force || removed.is_empty() {
            return Ok(());
        }
        Err(Error::Refused(format!("{}; nothing was sent (use --force to write it anyway)", removed.join("; "))))
    }
}

/// A parameter name or id resolved against the table.
pub fn resolve_param(text: &str) -> Result<&'static ParamDef, Error> {
    table::resolve_param(text).ok_or_else(|| {
        Error::Refused(format!(
            "unknown parameter {text:?}: use a manual name such as ActPos or an id such as 60 or 0x3c"
        ))
    })
}

/// The parameters a read asks for: every readable one, or the named ones,
/// each of which must be readable.
pub fn readable_params(names: &[String], all: bool) -> Result<Vec<&'static ParamDef>, Error> {
    if all {
        return Ok(table::PARAMS.iter().filter(|d| d.access.readable()).collect());
    }
    let defs = names.iter().map(|n| resolve_param(n)).collect::<Result<Vec<_>, _>>()?;
    if let Some(d) = defs.iter().find(|d| !d.access.readable()) {
        return Err(Error::Refused(format!(
            "{} ({:#04x}) is not readable (the manual marks it write-only)",
            d.name, d.id
        )));
    }
    Ok(defs)
}

/// A parameter write, checked for access and the parameter's wire type.
pub fn param_write(name: &str, text: &str) -> Result<(&'static ParamDef, Value), Error> {
    let d = resolve_param(name)?;
    if !d.access.writable() {
        return Err(Error::Refused(format!("{} ({:#04x}) is read-only; nothing was sent", d.name, d.id)));
    }
    let value = Value::parse(d.ty, text).map_err(|e| Error::Refused(format!("{}: {e}; nothing was sent", d.name)))?;
    Ok((d, value))
}

/// The DIO outputs mask 0..15.
pub fn dio_outputs(text: &str) -> Result<u8, Error> {
    parse_int(text)
        .filter(|v| (0..=0xf).contains(v))
        .map(|v| v as u8)
        .ok_or_else(|| Error::Refused(format!("--out {text:?} must be a 4-bit mask 0 to 15 (e.g. 0b0101)")))
}

/// A 32-bit word read as parameter `id`.
fn u32_of(id: u8, value: Value) -> Result<u32, Error> {
    match value {
        Value::UInt32(v) => Ok(v),
        other => Err(Error::UnexpectedType { param: param(id).name, got: format!("{other:?}") }),
    }
}

/// Whether a Config word describes a linear module.
pub fn is_linear(config_word: u32) -> bool {
    config_word & config::LINEAR != 0
}

/// A read sent by [`Cubes::send_read`] whose answers are still to be collected.
#[derive(Debug)]
#[must_use = "a read sent is collected or abandoned"]
pub struct SentRead {
    module: ModuleId,
    has: Vec<bool>,
    asked: Vec<u8>,
    burst: crate::session::powercube::Burst,
}

impl SentRead {
    pub fn module(&self) -> ModuleId {
        self.module
    }
}

/// The PowerCube modules reached through one session.
pub struct Cubes {
    pc: PowerCube,
    /// DefCubeVersion per module id, read once when a read needs it.
    versions: BTreeMap<u8, u16>,
    /// The watchdog policy of supervised motions, and what the current one armed.
    deadman: Deadman,
    armed: Option<deadman::Armed>,
    /// Told before a motion that goes out but deserves a word ([`Self::warn_with`]).
    warn: Option<fn(&str)>,
}

impl Cubes {
    pub fn new(pc: PowerCube) -> Self {
        Self { pc, versions: BTreeMap::new(), deadman: Deadman::default(), armed: None, warn: None }
    }

    /// Where a warning goes before a motion is sent: a module that was never
    /// homed (CubeState without HOME_OK) moves, but its position limits mean
    /// nothing yet. A warning, not a refusal: moving it by hand is how one
    /// gets it clear to home.
    pub fn warn_with(&mut self, say: fn(&str)) {
        self.warn = Some(say);
    }

    /// The module's firmware version (DefCubeVersion), read once.
    pub fn version(&mut self, m: ModuleId) -> Result<u16, Error> {
        if let Some(v) = self.versions.get(&m.get()) {
            return Ok(*v);
        }
        let v = self.pc.get(m, param(ids::DEF_CUBE_VERSION))?.as_f64().unwrap_or(0.0) as u16;
        self.versions.insert(m.get(), v);
        Ok(v)
    }

    /// Which of `params` the module's firmware has (the version is read only
    /// when one of them needs a newer firmware).
    fn has_params(&mut self, m: ModuleId, params: &[u8]) -> Result<Vec<bool>, Error> {
        if params.iter().all(|p| table::firmware_has(0, *p)) {
            return Ok(vec![true; params.len()]);
        }
        let version = self.version(m)?;
        Ok(params.iter().map(|p| table::firmware_has(version, *p)).collect())
    }

    /// Reads the parameters the module's firmware has, in one go; `None` for
    /// those it lacks (not asked for: the module would not answer).
    pub fn get_present(&mut self, m: ModuleId, defs: &[&'static ParamDef]) -> Result<Vec<Option<Value>>, Error> {
        let ids: Vec<u8> = defs.iter().map(|d| d.id).collect();
        let has = self.has_params(m, &ids)?;
        let asked: Vec<_> = defs.iter().zip(&has).filter(|(_, h)| **h).map(|(d, _)| *d).collect();
        let mut got = self.get_many(m, &asked)?.into_iter();
        Ok(has.iter().map(|h| if *h { got.next() } else { None }).collect())
    }

    /// The named parameters of one module, or with `all` every readable one
    /// its firmware has. Naming one its firmware lacks is refused: the
    /// module would not answer it.
    pub fn get_params(
        &mut self,
        m: ModuleId,
        defs: &[&'static ParamDef],
        all: bool,
    ) -> Result<Vec<(&'static ParamDef, Value)>, Error> {
        if let (false, Some(reqs)) = (all, Self::param_requests(m, defs)) {
            let answers = self.pc.transact_many(&reqs)?;
            return self.params_answered(m, defs, answers);
        }
        let got = self.get_present(m, defs)?;
        if !all {
            if let Some((d, _)) = defs.iter().zip(&got).find(|(_, v)| v.is_none()) {
                let version = self.version(m)?;
                return Err(Error::Refused(format!(
                    "module {m} runs firmware {}, which has no {} ({:#04x}); it came with {}",
                    version_text(version),
                    d.name,
                    d.id,
                    version_text(table::MEASUREMENTS_SINCE)
                )));
            }
        }
        Ok(defs.iter().zip(got).filter_map(|(d, v)| Some((*d, v?))).collect())
    }

    pub fn session(&mut self) -> &mut PowerCube {
        &mut self.pc
    }

    /// The requests of [`Self::get_params`] for the named `defs`, when they
    /// are known before anything is sent: `None` when one of the parameters
    /// needs a newer firmware, whose version is read (and decided on) first.
    /// A caller may send them in a larger burst of its own (`batch`
    /// pipelines consecutive reads) and hand the answers to
    /// [`Self::params_answered`]: the frames are those `get_params` sends.
    pub fn param_requests(m: ModuleId, defs: &[&'static ParamDef]) -> Option<Vec<(ModuleId, Request)>> {
        defs.iter().all(|d| table::firmware_has(0, d.id)).then(|| Self::get_requests(m, defs))
    }

    /// [`Self::get_params`] (named parameters) from the answers to
    /// [`Self::param_requests`], in request order: a read the burst did not
    /// answer is retried on its own (the burst counts as its first attempt).
    pub fn params_answered(
        &mut self,
        m: ModuleId,
        defs: &[&'static ParamDef],
        answers: impl IntoIterator<Item = Result<Response, SessionError>>,
    ) -> Result<Vec<(&'static ParamDef, Value)>, Error> {
        Ok(defs.iter().copied().zip(self.get_answered(m, defs, answers)?).collect())
    }

    fn get_requests(m: ModuleId, defs: &[&'static ParamDef]) -> Vec<(ModuleId, Request)> {
        defs.iter().map(|d| (m, Request::GetExtended { param: d.id })).collect()
    }

    /// Reads several parameters of one module, pipelined on CAN. A read the
    /// burst did not answer is retried one by one (the burst counts as its
    /// first attempt).
    pub fn get_many(&mut self, m: ModuleId, defs: &[&'static ParamDef]) -> Result<Vec<Value>, Error> {
        let answers = self.pc.transact_many(&Self::get_requests(m, defs))?;
        self.get_answered(m, defs, answers)
    }

    /// The values of `defs` from the answers to their GetExtended requests,
    /// in order; a missing or bad answer is retried on its own, and the
    /// first read that still fails ends the lot.
    fn get_answered(
        &mut self,
        m: ModuleId,
        defs: &[&'static ParamDef],
        answers: impl IntoIterator<Item = Result<Response, SessionError>>,
    ) -> Result<Vec<Value>, Error> {
        defs.iter()
            .zip(answers)
            .map(|(d, a)| {
                let resp = match a {
                    Ok(r) => r,
                    Err(e) => self.pc.retry_read(m, &Request::GetExtended { param: d.id }, e)?,
                };
                Ok(decode_get(m, d, &resp)?)
            })
            .collect()
    }

    /// One pipelined burst, no retries: the first failure fails the lot. A
    /// poll is repeated anyway, and a late one is worse than a missed one.
    /// A parameter the module's firmware lacks reads NaN without being asked.
    pub fn read_now(&mut self, m: ModuleId, params: &[u8]) -> Result<Vec<f64>, Error> {
        let read = self.send_read(m, params)?;
        self.collect_read(read)
    }

    /// The send half of [`Self::read_now`]: the burst goes out and its
    /// answers are left for [`Self::collect_read`], so that other requests
    /// (the next module's read, an action) can go out meanwhile.
    pub fn send_read(&mut self, m: ModuleId, params: &[u8]) -> Result<SentRead, Error> {
        let has = self.has_params(m, params)?;
        let asked: Vec<u8> = params.iter().zip(&has).filter(|(_, h)| **h).map(|(p, _)| *p).collect();
        let reqs: Vec<_> = asked.iter().map(|p| (m, Request::GetExtended { param: *p })).collect();
        let burst = self.pc.send_burst(&reqs)?;
        Ok(SentRead { module: m, has, asked, burst })
    }

    /// The values of a read sent with [`Self::send_read`], as [`Self::read_now`] gives them.
    pub fn collect_read(&mut self, read: SentRead) -> Result<Vec<f64>, Error> {
        let SentRead { module: m, has, asked, burst } = read;
        let answers = self.pc.collect(burst)?.answers;
        let mut got = asked
            .iter()
            .zip(answers)
            .map(|(p, a)| -> Result<f64, Error> { Ok(decode_get(m, param(*p), &a?)?.as_f64().unwrap_or(f64::NAN)) });
        has.iter()
            .map(|h| if *h { got.next().expect("one answer per asked parameter") } else { Ok(f64::NAN) })
            .collect()
    }

    /// Gives up a read sent with [`Self::send_read`] without waiting for it.
    pub fn abandon_read(&mut self, read: SentRead) {
        self.pc.abandon(read.burst);
    }

    pub fn get_u32(&mut self, m: ModuleId, id: u8) -> Result<u32, Error> {
        u32_of(id, self.pc.get(m, param(id))?)
    }

    /// CubeState.
    pub fn state(&mut self, m: ModuleId) -> Result<u32, Error> {
        self.get_u32(m, ids::CUBE_STATE)
    }

    /// [`Self::state`] from the answer to its request (the one of
    /// [`Self::param_requests`] for CubeState), sent in a burst: retried on
    /// its own when the burst did not answer it.
    pub fn state_answered(&mut self, m: ModuleId, answer: Result<Response, SessionError>) -> Result<u32, Error> {
        let values = self.get_answered(m, &[param(ids::CUBE_STATE)], [answer])?;
        let [value] = <[Value; 1]>::try_from(values).expect("one read, one value");
        u32_of(ids::CUBE_STATE, value)
    }

    /// Motion is refused while the module reports an error or is halted: it
    /// would not move, and the user should reset it first.
    pub fn ensure_ready(&mut self, m: ModuleId) -> Result<(), Error> {
        let state = self.state(m)?;
        if let Some(why) = limits::not_ready(state) {
            return Err(Error::NotReady { module: m, why });
        }
        if let Some(say) = self.warn.filter(|_| state & crate::proto::powercube::flags::state::HOME_OK == 0) {
            say(&format!(
                "module {m} was not homed (CubeState lacks HOME_OK): its position and limits mean nothing yet"
            ));
        }
        Ok(())
    }

    /// The module's own limits (units, or encoder ticks).
    pub fn limits(&mut self, m: ModuleId, ticks: bool) -> Result<Limits, Error> {
        let defs: Vec<_> = Limits::param_ids(ticks).iter().map(|id| param(*id)).collect();
        let v = self.get_many(m, &defs)?;
        Ok(Limits::from_values([0, 1, 2, 3, 4].map(|i| v[i].as_f64().unwrap_or(f64::NAN)), ticks))
    }

    /// Whether the module is linear, and its limits in units, in one burst
    /// without retries (what a dashboard poll needs once per module).
    pub fn kind_and_limits(&mut self, m: ModuleId) -> Result<(bool, Limits), Error> {
        let mut params = vec![ids::CONFIG];
        params.extend(Limits::param_ids(false));
        let v = self.read_now(m, &params)?;
        Ok((is_linear(v[0] as u32), Limits::from_values([v[1], v[2], v[3], v[4], v[5]], false)))
    }

    /// The ids among `candidates` that answer DefCubeVersion, with the
    /// version; a module that does not answer in time is absent, any other
    /// failure ends the scan.
    pub fn scan(&mut self, candidates: &[ModuleId]) -> Result<Vec<Found>, Error> {
        let probes: Vec<_> =
            candidates.iter().map(|m| (*m, Request::GetExtended { param: ids::DEF_CUBE_VERSION })).collect();
        let answers = self.pc.transact_many(&probes)?;
        let mut found = Vec::new();
        for ((m, _), a) in probes.iter().zip(answers) {
            match a {
                Ok(resp) => {
                    found.push(Found { module: *m, version: decode_get(*m, param(ids::DEF_CUBE_VERSION), &resp)? })
                }
                Err(SessionError::Timeout { .. }) => {}
                Err(e) => return Err(e.into()),
            }
        }
        Ok(found)
    }

    /// Ids 1..=31 that answer DefCubeVersion (one pipelined probe each; any
    /// failure counts as absent).
    pub fn present(&mut self) -> Result<Vec<ModuleId>, Error> {
        let probes: Vec<_> =
            ModuleId::all().map(|m| (m, Request::GetExtended { param: ids::DEF_CUBE_VERSION })).collect();
        let answers = self.pc.transact_many(&probes)?;
        Ok(probes.iter().zip(answers).filter(|(_, a)| a.is_ok()).map(|((m, _), _)| *m).collect())
    }

    /// Home, Reset or Halt to one module (acknowledged), or broadcast to all
    /// (`None`; never acknowledged). Home is exactly one frame: no state is
    /// read first, a faulted module shows up while waiting.
    pub fn simple(&mut self, target: Option<ModuleId>, cmd: Simple) -> Result<(), Error> {
        match target {
            Some(m) => self.pc.transact(m, &cmd.request()).map(|_| ())?,
            None => self.pc.broadcast(cmd.broadcast())?,
        }
        Ok(())
    }

    /// Home to one module under supervision: a Home without its
    /// acknowledge may still have been taken, so the module is halted before
    /// the error is returned. Config is read first, for the dead-man
    /// backstop (is the watchdog on?).
    pub fn home_supervised(&mut self, m: ModuleId, halt_attempts: u32) -> Result<(), Error> {
        if supervisor::stop_requested() {
            return Err(Error::InterruptedBefore { what: format!("Home to module {m}"), halted: Vec::new() });
        }
        self.arm_deadman(&[(m, None)])?;
        match self.pc.transact(m, &Simple::Home.request()) {
            Ok(_) => Ok(()),
            Err(source) => {
                let halt_failed = self.halt_retrying(m, halt_attempts).err().map(|e| e.to_string());
                Err(Error::MotionUnconfirmed { what: "Home".into(), module: m, halt_failed, source })
            }
        }
    }

    /// Home to each of `modules` under supervision, one acknowledged Home
    /// each (not the broadcast: it would also start a module whose presence
    /// answer was lost, which nobody would then watch). A Home without its
    /// acknowledge may still have been taken, so that module and every one
    /// homed before it are halted before the error is returned. Once
    /// `interrupted`, no further Home goes out and those sent are halted.
    pub fn home_each_supervised(
        &mut self,
        modules: &[ModuleId],
        halt_attempts: u32,
        interrupted: &dyn Fn() -> bool,
    ) -> Result<(), Error> {
        let unread: Vec<_> = modules.iter().map(|m| (*m, None)).collect();
        self.arm_deadman(&unread)?;
        for (i, &m) in modules.iter().enumerate() {
            if interrupted() {
                let halted = self.halt_each(&modules[..i], halt_attempts);
                return Err(Error::InterruptedBefore { what: format!("Home to module {m}"), halted });
            }
            if let Err(source) = self.pc.transact(m, &Simple::Home.request()) {
                let halted = self.halt_each(&modules[..=i], halt_attempts);
                return Err(Error::MotionsUnconfirmed { what: "Home".into(), module: m, halted, source });
            }
        }
        Ok(())
    }

    /// [`Self::halt_retrying`] to each module, all of them whatever fails;
    /// whether each halt was acknowledged.
    pub fn halt_each(&mut self, modules: &[ModuleId], attempts: u32) -> Vec<(ModuleId, bool)> {
        modules.iter().map(|&m| (m, self.halt_retrying(m, attempts).is_ok())).collect()
    }

    /// Halt, sent again when its acknowledge does not come: stopping twice
    /// is harmless, not stopping is not. (Motion commands are never sent
    /// twice.)
    pub fn halt_retrying(&mut self, m: ModuleId, attempts: u32) -> Result<(), SessionError> {
        let mut last = None;
        for _ in 0..attempts.max(1) {
            match self.pc.transact(m, &Request::Halt) {
                Ok(_) => return Ok(()),
                Err(e @ (SessionError::Timeout { .. } | SessionError::Malformed { .. })) => last = Some(e),
                Err(e) => return Err(e),
            }
        }
        Err(last.expect("at least one attempt"))
    }

    /// The broadcast first (one frame stops every module on the bus, known
    /// or not, and needs no answer), then each known module's acknowledged
    /// Halt, once: a lost acknowledge costs one timeout per module.
    pub fn halt_all(&mut self, known: &[ModuleId]) -> HaltAll {
        let broadcast = self.simple(None, Simple::Halt);
        let modules = known.iter().map(|m| (*m, self.simple(Some(*m), Simple::Halt))).collect();
        HaltAll { broadcast, modules }
    }

    pub fn set_param(&mut self, m: ModuleId, d: &'static ParamDef, value: Value) -> Result<(), Error> {
        Ok(self.pc.set(m, d, value)?)
    }

    /// A parameter write from a person or a script. A target or a commanded
    /// current is checked as a move with that value would be: the manual's
    /// range and a positive velocity / acceleration always, the module's
    /// limits (read from it) unless `force`. Nothing is sent when a check
    /// refuses. Afterwards the value is read back where the manual lets it be
    /// read: the module may have clamped it. `None` for write-only ones.
    pub fn write_param(
        &mut self,
        m: ModuleId,
        d: &'static ParamDef,
        value: Value,
        force: bool,
    ) -> Result<Option<Value>, Error> {
        if let (Some(limit), Some(x)) = (limits::SettingLimit::of(d.id), value.as_f64()) {
            limit.check_manual(d.name, x)?;
            if let (Some(ticks), false) = (limit.module_limits(), force) {
                let l = self.limits(m, ticks)?;
                limit.check_module(x, &l, m)?;
            }
        }
        self.pc.set(m, d, value)?;
        if !d.access.readable() {
            return Ok(None);
        }
        Ok(Some(self.pc.get(m, d)?))
    }

    /// Writes Config and reads it back; a module that keeps another word is
    /// a fault (the caller gets the word it kept inside the error).
    pub fn write_config(&mut self, m: ModuleId, change: ConfigChange) -> Result<u32, Error> {
        let wanted = match change.raw {
            Some(v) => v,
            None => (self.get_u32(m, ids::CONFIG)? | change.set) & !change.clear,
        };
        self.pc.set(m, param(ids::CONFIG), Value::UInt32(wanted))?;
        let kept = self.get_u32(m, ids::CONFIG)?;
        if kept != wanted {
            return Err(Error::ConfigNotKept { module: m, wanted, kept });
        }
        Ok(kept)
    }

    /// DioSetup, after setting the outputs (bits 4..7) when given.
    pub fn dio(&mut self, m: ModuleId, outputs: Option<u8>) -> Result<u32, Error> {
        let mut raw = self.get_u32(m, ids::DIO_SETUP)?;
        if let Some(o) = outputs {
            raw = (raw & !0xf0) | (u32::from(o & 0xf) << 4);
            self.pc.set(m, param(ids::DIO_SETUP), Value::UInt32(raw))?;
            raw = self.get_u32(m, ids::DIO_SETUP)?;
        }
        Ok(raw)
    }

    /// The watchdog is a CAN feature: its refresh is a CAN broadcast.
    pub fn require_can_for_watchdog(&self) -> Result<(), Error> {
        if self.pc.is_can() {
            Ok(())
        } else {
            Err(Error::Refused("the watchdog is a CAN feature (its refresh is a CAN broadcast)".into()))
        }
    }

    /// Switches the watchdog online, unless CONFIGID_MOD_WATCHDOG_ENABLE
    /// says it is on already: 0x07 toggles, so a blind one would take an
    /// online watchdog offline. The module reports no online/offline state;
    /// the flag stands for it, because clearing the flag takes the watchdog
    /// offline (see [`Self::watchdog_off`]), so with the flag clear one 0x07
    /// after setting it brings the watchdog online. Returns whether anything
    /// changed.
    pub fn watchdog_on(&mut self, m: ModuleId) -> Result<bool, Error> {
        self.require_can_for_watchdog()?;
        if self.get_u32(m, ids::CONFIG)? & config::WATCHDOG_ENABLE != 0 {
            return Ok(false);
        }
        self.write_config(m, ConfigChange { set: config::WATCHDOG_ENABLE, ..ConfigChange::default() })?;
        self.pc.transact(m, &Request::Watchdog)?;
        Ok(true)
    }

    /// Takes the watchdog out of action by clearing
    /// CONFIGID_MOD_WATCHDOG_ENABLE (read back), and sends no 0x07: a toggle
    /// would switch an offline watchdog online, and the module would trip
    /// 50 ms later. Nothing is written when the flag is clear already.
    /// Returns whether anything changed.
    pub fn watchdog_off(&mut self, m: ModuleId) -> Result<bool, Error> {
        self.require_can_for_watchdog()?;
        if self.get_u32(m, ids::CONFIG)? & config::WATCHDOG_ENABLE == 0 {
            return Ok(false);
        }
        self.write_config(m, ConfigChange { clear: config::WATCHDOG_ENABLE, ..ConfigChange::default() })?;
        Ok(true)
    }
}
