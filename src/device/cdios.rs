//! Cdios 6168 operations on the modules of one node: checked goto / traject
//! / start / stop / enable / disable, status and positions, the dashboard's
//! poll, the module scan, halt-all, the waits for the end of a motion, the
//! servo configuration and the outputs, analog outputs and event masks.
//!
//! Every command is built and range-checked with the protocol table before
//! anything is sent; the CLI and the dashboard only word the outcome.

pub mod config;
mod error;
mod face;
mod io;
mod wait;

#[cfg(test)]
mod tests;

use crate::device::supervisor;
use crate::proto::cdios::table;
use crate::proto::cdios::{
    Address, Command, Direction, GotoMode, ModuleId, NodeId, PositionSource, StartOption, StatusReport, StatusSelector,
    StopOption, Traject, ValidationError,
};
use crate::session::cdios::Cdios;
use crate::session::{RetryPolicy, SessionError};

pub use error::Error;
pub use io::{analog_request, mask_flags, outputs_value, AnalogReading, EventChange, EventSetup};
pub use wait::{Goal, WaitEnd, WaitSpec};

/// Status 1 bits 0 and 1: running forward / reverse.
const RUNNING: u8 = 0x03;

/// A user value for a field of a table row, checked against the manual's
/// range and the field's wire type.
pub fn field_value<T: TryFrom<i64>>(row: &str, key: &str, v: i64) -> Result<T, Error> {
    let field = table::command(row).and_then(|d| d.field(key)).expect("row and field are in the table");
    field.check(v)?;
    T::try_from(v).map_err(|_| {
        Error::Invalid(ValidationError::OutOfRange { field: field.key, value: v, min: field.min, max: field.max })
    })
}

/// A position typed as a number (the dashboard's goto): a whole number of
/// counts within the row's position field.
pub fn check_position(row: &str, v: f64) -> Result<i32, Error> {
    if v.fract() != 0.0 || !v.is_finite() {
        return Err(Error::Refused(format!("position {v} is not a whole number of counts; nothing was sent")));
    }
    field_value(row, "position", v as i64)
}

/// Encodes (and so range-checks) every command; nothing is sent.
pub fn check(cmds: &[Command], m: ModuleId) -> Result<(), Error> {
    for c in cmds {
        c.encode(Address::Module(m))?;
    }
    Ok(())
}

/// A goto, with its speed first when given.
pub fn goto_commands(mode: GotoMode, position: i64, speed: Option<i64>) -> Result<Vec<Command>, Error> {
    let position = field_value::<i32>("goto", "position", position)?;
    let speed = speed.map(|v| field_value::<u16>("goto_next_speed", "speed", v)).transpose()?;
    let mut cmds = Vec::new();
    if let Some(speed) = speed {
        cmds.push(Command::SetNextGotoSpeed { speed });
    }
    cmds.push(Command::Goto { mode, position });
    Ok(cmds)
}

/// The table's name of a goto mode, e.g. `absolute`.
pub fn mode_name(mode: GotoMode) -> &'static str {
    table::command("goto").and_then(|d| d.selector(mode.to_u8())).map_or("?", |s| s.key)
}

/// A traject run, traject 0 or 1.
pub fn traject_command(traject: i64, latched: bool) -> Result<Command, Error> {
    let n = field_value::<u8>("goto_traject", "traject", traject)?;
    let traject = Traject::from_u8(n).expect("checked 0..=1 by the table");
    Ok(Command::GotoTraject { traject, sync: latched })
}

/// A start; a motor speed goes only with [`StartOption::ToSpeed`], which
/// needs one.
pub fn start_command(
    direction: Direction,
    option: StartOption,
    speed: Option<i64>,
    latched: bool,
) -> Result<Command, Error> {
    if option == StartOption::ToSpeed && speed.is_none() {
        return Err(Error::Refused("--option to-speed needs --speed RPM; nothing was sent".into()));
    }
    if option != StartOption::ToSpeed && speed.is_some() {
        return Err(Error::Refused("--speed is used only with --option to-speed; nothing was sent".into()));
    }
    let motor_speed = field_value::<u16>("start", "motor_speed", speed.unwrap_or(0))?;
    Ok(Command::Start { sync: latched, direction, option, motor_speed })
}

/// Switches the servo on, after releasing an emergency stop when asked.
pub fn enable_commands(release_emergency: bool) -> Vec<Command> {
    let enable =
        Command::Start { sync: false, direction: Direction::Forward, option: StartOption::Enable, motor_speed: 0 };
    let release = Command::Stop { sync: false, option: StopOption::ReleaseEmergency };
    if release_emergency {
        vec![release, enable]
    } else {
        vec![enable]
    }
}

pub fn stop_command(option: StopOption, latched: bool) -> Command {
    Command::Stop { sync: latched, option }
}

/// The fast stop that halts a motor.
pub const FAST_STOP: Command = Command::Stop { sync: false, option: StopOption::FastStop };

/// Whether `e` is a module's refusal of a stop because its motor is not
/// running, and for no other reason: the state the stop asked for. (The
/// manual's error reply names MOTOR_NOT_RUNNING alone, general code 0.)
pub fn refused_as_not_running(e: &Error) -> bool {
    matches!(e.refusal(), Some(crate::proto::Refusal::Cdios(r))
        if r.general == 0 && r.unknown_bits.is_empty() && r.errors.iter().map(|b| b.name).eq(["MOTOR_NOT_RUNNING"]))
}

/// How a module took a stop or a halt-all.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stopped {
    /// The stop was taken and confirmed (`false`: sent, confirmations are off).
    FastStop { confirmed: bool },
    /// The module refused the stop because its motor is not running.
    NotRunning,
}

/// A poll sent by [`Node::send_poll`] whose replies are still to be collected.
#[derive(Debug)]
#[must_use = "a poll sent is collected or abandoned"]
pub struct SentPoll {
    module: ModuleId,
    reads: crate::session::cdios::SentReads,
}

impl SentPoll {
    pub fn module(&self) -> ModuleId {
        self.module
    }
}

/// A module as the dashboard polls it.
#[derive(Debug, Clone, PartialEq)]
pub struct Reading {
    pub position: i64,
    pub setpoint: i64,
    pub speed: i64,
    pub rpm_error: i64,
    pub status: [u8; 4],
}

/// One slot of the controller's identify answer.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Slot {
    pub module: u8,
    pub ty: i64,
    pub version: i64,
}

/// A probe's outcome: any answer, a refusal too, says the node runs.
fn answered(r: Result<Option<StatusReport>, SessionError>) -> Result<Option<StatusReport>, Error> {
    match r {
        Err(SessionError::Device { .. } | SessionError::Malformed { .. }) => Ok(None),
        other => Ok(other?),
    }
}

/// The 6168 modules of one node.
pub struct Node {
    s: Cdios,
    node: NodeId,
    /// The session's read retries, restored after a scan (which reads once).
    retry: RetryPolicy,
}

impl Node {
    pub fn new(s: Cdios, node: NodeId, retry: RetryPolicy) -> Self {
        Self { s, node, retry }
    }

    pub fn id(&self) -> NodeId {
        self.node
    }

    /// The next command would first wake the node (probe, NMT start).
    pub fn needs_wake(&self) -> bool {
        self.s.needs_start(self.node)
    }

    pub fn session(&mut self) -> &mut Cdios {
        &mut self.s
    }

    /// The session back, to talk to another node on the same link.
    pub fn into_session(self) -> Cdios {
        self.s
    }

    /// Checks every command, then sends them one after the other, each
    /// awaited. `true` when every one was confirmed (confirmations can be
    /// switched off).
    pub fn send(&mut self, m: ModuleId, cmds: &[Command]) -> Result<bool, Error> {
        check(cmds, m)?;
        self.ready(m)?;
        let mut confirmed = true;
        for c in cmds {
            confirmed &= self.s.transact(self.node, Address::Module(m), c)?.is_some();
        }
        Ok(confirmed)
    }

    /// [`Self::send`] under supervision: a motion command that went out
    /// without its answer may still have been taken, so the motor is
    /// stopped (up to `stop_attempts` times) before the error is returned.
    /// An error reply from the node needs no stop.
    pub fn send_supervised(&mut self, m: ModuleId, cmds: &[Command], stop_attempts: u32) -> Result<bool, Error> {
        // The node has answered (after its NMT start and settle time, if it
        // needed one) before the last look: a signal until then means the
        // motion is not sent at all.
        check(cmds, m)?;
        self.ready(m)?;
        if supervisor::stop_requested() {
            return Err(Error::InterruptedBefore { node: self.node, module: m });
        }
        match self.send(m, cmds) {
            Err(Error::Session(source)) if source.refusal().is_none() => {
                let stop_failed = self.stop_retrying(m, stop_attempts).err().map(|e| e.to_string());
                let what = "motion command, not acknowledged: the module may have been moving".into();
                Err(Error::LostTrack { node: self.node, module: m, what, stop_failed, source })
            }
            other => other,
        }
    }

    /// Makes sure the node runs before its first command, without the
    /// 100 ms of an NMT start each time: a status read of `m` asks it first,
    /// once, without retries. Only when nothing answers does the node get
    /// the NMT start and its settle time, then the read again, which must be
    /// answered (with the read retries). So a running node costs one read,
    /// and no command, motion above all, goes to a node that has not
    /// answered. Nothing is asked when the node answered before or the
    /// caller said it runs (`--no-nmt`).
    pub fn ready(&mut self, m: ModuleId) -> Result<(), Error> {
        self.wake(Address::Module(m)).map(drop)
    }

    /// [`Self::ready`] with a read of `address`; `Some`: the status of the
    /// module asked, read just now.
    fn wake(&mut self, address: Address) -> Result<Option<StatusReport>, Error> {
        if !self.s.needs_start(self.node) {
            return Ok(None);
        }
        // The probe must go out without the session's own NMT start.
        self.s.mark_running(self.node);
        self.s.set_retry(RetryPolicy { read_retries: 0 });
        let first = self.probe(address);
        self.s.set_retry(self.retry);
        match first {
            Err(SessionError::Timeout { .. }) => {}
            other => return answered(other),
        }
        self.s.send_start(self.node)?;
        let second = answered(self.probe(address));
        if second.is_err() {
            self.s.forget_running(self.node);
        }
        second
    }

    fn probe(&mut self, address: Address) -> Result<Option<StatusReport>, SessionError> {
        match address {
            Address::Module(m) => self.s.read_status(self.node, m).map(Some),
            Address::Controller => self.s.read(self.node, address, &Command::Identify { selector: 0 }).map(|_| None),
        }
    }

    pub fn status(&mut self, m: ModuleId) -> Result<StatusReport, Error> {
        if let Some(r) = self.wake(Address::Module(m))? {
            return Ok(r);
        }
        Ok(self.s.read_status(self.node, m)?)
    }

    /// Motor speed and RPM error.
    pub fn speed(&mut self, m: ModuleId) -> Result<(i64, i64), Error> {
        self.ready(m)?;
        Ok(self.s.read_speed(self.node, m)?)
    }

    pub fn position(&mut self, m: ModuleId, source: PositionSource) -> Result<i32, Error> {
        self.ready(m)?;
        Ok(self.s.read_position(self.node, m, source)?)
    }

    /// The controller's module slots (eight identify reads of two slots).
    pub fn identify(&mut self) -> Result<Vec<Slot>, Error> {
        self.wake(Address::Controller)?;
        let mut out = Vec::new();
        for selector in 0..=7u8 {
            let r = self.s.read(self.node, Address::Controller, &Command::Identify { selector })?;
            for (i, (ty, ver)) in
                [("first_type", "first_version"), ("second_type", "second_version")].iter().enumerate()
            {
                out.push(Slot {
                    module: 2 * selector + i as u8,
                    ty: r.get(ty).unwrap_or(0),
                    version: r.get(ver).unwrap_or(0),
                });
            }
        }
        Ok(out)
    }

    /// One burst per poll: status, speed, position, setpoint.
    pub fn poll(&mut self, m: ModuleId) -> Result<Reading, Error> {
        let sent = self.send_poll(m)?;
        self.collect_poll(sent)
    }

    /// The send half of [`Self::poll`]: the burst goes out and its replies
    /// are left for [`Self::collect_poll`], so that other commands (the next
    /// module's poll, an action) can go out meanwhile.
    pub fn send_poll(&mut self, m: ModuleId) -> Result<SentPoll, Error> {
        self.ready(m)?;
        let cmds = [
            Command::ReadStatus(StatusSelector::Status),
            Command::ReadStatus(StatusSelector::SpeedError),
            Command::ReadPosition(PositionSource::Current),
            Command::ReadPosition(PositionSource::Setpoint),
        ];
        Ok(SentPoll { module: m, reads: self.s.send_many(self.node, Address::Module(m), &cmds)? })
    }

    /// The reading of a poll sent with [`Self::send_poll`].
    pub fn collect_poll(&mut self, sent: SentPoll) -> Result<Reading, Error> {
        let replies = self.s.collect_many(sent.reads)?;
        let get = |i: usize, k: &str| replies[i].get(k).unwrap_or(0);
        let byte = |k| get(0, k) as u8;
        Ok(Reading {
            position: get(2, "position"),
            setpoint: get(3, "position"),
            speed: get(1, "motor_speed"),
            rpm_error: get(1, "rpm_error"),
            status: [byte("status1"), byte("status2"), byte("status3"), byte("status4")],
        })
    }

    /// Gives up a poll sent with [`Self::send_poll`] without waiting for it.
    pub fn abandon_poll(&mut self, sent: SentPoll) {
        self.s.abandon_many(sent.reads);
    }

    /// The modules 0..=15 that answer a status read. An absent one times out
    /// (or is refused by the controller), so each is read once, without
    /// retries; a link failure ends the scan.
    pub fn scan(&mut self) -> Result<Vec<ModuleId>, Error> {
        self.wake(Address::Controller)?;
        self.s.set_retry(RetryPolicy { read_retries: 0 });
        let mut found = Vec::new();
        let mut failed = None;
        for m in ModuleId::all() {
            match self.s.read_status(self.node, m) {
                Ok(_) => found.push(m),
                Err(e @ SessionError::Link(_)) => {
                    failed = Some(e);
                    break;
                }
                Err(_) => {}
            }
        }
        self.s.set_retry(self.retry);
        match failed {
            Some(e) => Err(e.into()),
            None => Ok(found),
        }
    }

    /// Fast stop, sent again when no confirmation comes: stopping twice is
    /// harmless, not stopping is not.
    pub fn stop_retrying(&mut self, m: ModuleId, attempts: u32) -> Result<(), SessionError> {
        let mut last = None;
        for _ in 0..attempts.max(1) {
            match self.s.transact(self.node, Address::Module(m), &FAST_STOP) {
                Ok(_) => return Ok(()),
                Err(e @ (SessionError::Timeout { .. } | SessionError::Malformed { .. })) => last = Some(e),
                Err(e) => return Err(e),
            }
        }
        Err(last.expect("at least one attempt"))
    }

    /// A stop that a person or a script asked for (`cdios-stop`): a motor
    /// already at rest is the state asked for, so when the node refuses the
    /// stop and its status says the motor does not run, that is
    /// [`Stopped::NotRunning`], not a failure. Any other refusal, or one
    /// whose status cannot be read, stays an error: the motor may move.
    /// Options that do not stop a motor (release the emergency stop, clear a
    /// hold) are sent as they are: their refusal is an answer to keep.
    pub(crate) fn stop(&mut self, m: ModuleId, option: StopOption, latched: bool) -> Result<Stopped, Error> {
        let stops =
            matches!(option, StopOption::FastStop | StopOption::DecelerateAndStop | StopOption::DecelerateToMinimum);
        match self.send(m, &[stop_command(option, latched)]) {
            Ok(confirmed) => Ok(Stopped::FastStop { confirmed }),
            Err(e @ Error::Session(SessionError::Device { .. })) if stops => match self.s.read_status(self.node, m) {
                Ok(st) if st.status[0] & RUNNING == 0 => Ok(Stopped::NotRunning),
                _ => Err(e),
            },
            Err(e) => Err(e),
        }
    }

    /// Whether the motor of `m` runs (status 1, bits 0 and 1).
    pub fn running(&mut self, m: ModuleId) -> Result<bool, Error> {
        Ok(self.status(m)?.status[0] & RUNNING != 0)
    }

    /// The stop of a way out of a motion ([`Self::stop_retrying`]):
    /// `Ok(true)` when it was taken, `Ok(false)` when the module refused it
    /// because its motor had come to rest by itself, the state asked for.
    pub fn halt_motor(&mut self, m: ModuleId, attempts: u32) -> Result<bool, Error> {
        match self.stop_retrying(m, attempts) {
            Ok(()) => Ok(true),
            Err(e) => match Error::from(e) {
                e if refused_as_not_running(&e) => Ok(false),
                e => Err(e),
            },
        }
    }

    /// A fast stop to each module, once. A motor that is not running
    /// refuses a stop: that is no failure.
    pub fn halt_all(&mut self, known: &[ModuleId]) -> Vec<(ModuleId, Result<Stopped, Error>)> {
        known
            .iter()
            .map(|&m| {
                let r = match self.send(m, &[FAST_STOP]) {
                    Ok(confirmed) => Ok(Stopped::FastStop { confirmed }),
                    Err(Error::Session(SessionError::Device { .. }))
                        if self.s.read_status(self.node, m).is_ok_and(|st| st.status[0] & RUNNING == 0) =>
                    {
                        Ok(Stopped::NotRunning)
                    }
                    Err(e) => Err(e),
                };
                (m, r)
            })
            .collect()
    }
}
