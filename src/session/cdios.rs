//! The Cdios session: commands to `0x200 + node`, answers from `0x180 + node`
//! (specs README, "Cdios 6168"), one command at a time.
//!
//! - The node is started with NMT once per node and given 100 ms to settle,
//!   unless the caller says it runs already ([`Cdios::set_nmt`]).
//! - A reply matches by node, code (11h for reading the digital outputs),
//!   module byte and, where the reply echoes it, the selector.
//! - An error reply (code | 0x80; 56h or 96h for 16h) to the command becomes
//!   [`SessionError::Device`] with the general error text and the command's
//!   status bits decoded.
//! - Events (code | 0x40) are queued for the caller ([`Cdios::take_events`]),
//!   never taken for replies; frames of other families (PowerCube ids) and
//!   of other nodes are ignored.
//! - Nodes whose 'Confirm' is 0 send no confirmation ([`Cdios::set_confirm`]):
//!   then only an error is awaited, for a short window; reads and 05h are
//!   always answered and are awaited as usual.
//! - Reads are retried after a timeout or a malformed answer, and while the
//!   controller is busy (initialising, programming EEPROM); nothing else is,
//!   motion above all.

use std::collections::VecDeque;
use std::sync::Arc;
use std::time::{Duration, Instant};

use super::{RetryPolicy, SessionError, TraceEvent, Tracer};
use crate::clock::{Clock, SystemClock};
use crate::link::CanLink;
use crate::proto::cdios::table::{self, Confirm, DecodedReply, ReplySelector};
use crate::proto::cdios::transport::{self, Answer, AnswerKind};
use crate::proto::cdios::{
    decode_status, Address, Command, ErrorReply, ModuleId, NodeId, PositionSource, StatusReport, StatusSelector,
};
use crate::proto::{CanFrame, DecodeError};

/// Default answer timeout on CAN (as for PowerCube).
pub const TIMEOUT: Duration = Duration::from_millis(100);
/// How long an error is awaited for a confirmation that is switched off.
pub const NO_CONFIRM_WINDOW: Duration = Duration::from_millis(50);
/// 05h: "EEPROM erasing / programming takes 260 up to 750 milliseconds, then
/// the reply message is sent"; this is on top of the normal timeout.
pub const STORE_TIME: Duration = Duration::from_millis(750);
/// A read refused because the controller is busy is tried again after this...
pub const BUSY_RETRY_INTERVAL: Duration = Duration::from_millis(50);
/// ...until this much time has passed (longer than an EEPROM write and the
/// 500 ms of initialisation).
pub const BUSY_RETRY_LIMIT: Duration = Duration::from_millis(1000);
/// Events kept for the caller; older ones are dropped (and counted).
pub const EVENT_QUEUE: usize = 1024;
/// Most stale frames dropped before a command.
const MAX_DRAIN: usize = 256;

/// General error codes after which the same read may succeed a little later.
const GENERAL_INITIALISING: u8 = 4;
const GENERAL_EEPROM_BUSY: u8 = 8;

/// An unsolicited answer (code | 0x40), as received.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Event {
    pub at: Instant,
    pub answer: Answer,
}

impl Event {
    /// The event decoded with the reply layout of its command.
    pub fn decoded(&self) -> Option<DecodedReply> {
        self.answer.reply().and_then(Result::ok)
    }
}

/// Why one attempt failed: a device refusal keeps its reply so that busy
/// errors can be told apart before they become a [`SessionError`].
enum Failure {
    Session(SessionError),
    Refused(ErrorReply),
}

impl From<SessionError> for Failure {
    fn from(e: SessionError) -> Self {
        Self::Session(e)
    }
}

impl From<crate::link::LinkError> for Failure {
    fn from(e: crate::link::LinkError) -> Self {
        Self::Session(e.into())
    }
}

pub struct Cdios {
    link: Box<dyn CanLink>,
    timeout: Duration,
    retry: RetryPolicy,
    tracer: Option<Tracer>,
    clock: Arc<dyn Clock>,
    nmt: bool,
    started: Vec<NodeId>,
    confirm: bool,
    events: VecDeque<Event>,
    dropped_events: u64,
}

impl Cdios {
    pub fn new(link: Box<dyn CanLink>) -> Self {
        Self {
            link,
            timeout: TIMEOUT,
            retry: RetryPolicy::default(),
            tracer: None,
            clock: Arc::new(SystemClock),
            nmt: true,
            started: Vec::new(),
            confirm: true,
            events: VecDeque::new(),
            dropped_events: 0,
        }
    }

    /// The clock deadlines and the NMT settle time are measured on.
    pub fn with_clock(mut self, clock: Arc<dyn Clock>) -> Self {
        self.clock = clock;
        self
    }

    pub fn clock(&self) -> &Arc<dyn Clock> {
        &self.clock
    }

    pub fn set_timeout(&mut self, timeout: Duration) {
        self.timeout = timeout;
    }

    pub fn timeout(&self) -> Duration {
        self.timeout
    }

    pub fn set_retry(&mut self, retry: RetryPolicy) {
        self.retry = retry;
    }

    pub fn set_tracer(&mut self, tracer: Tracer) {
        self.tracer = Some(tracer);
    }

    /// `false`: the nodes are operational already; no NMT start is sent.
    pub fn set_nmt(&mut self, nmt: bool) {
        self.nmt = nmt;
    }

    /// `false`: the controller's 'Confirm' is 0, confirmations are not sent.
    pub fn set_confirm(&mut self, confirm: bool) {
        self.confirm = confirm;
    }

    fn trace(&mut self, ev: impl FnOnce() -> TraceEvent) {
        if let Some(t) = self.tracer.as_mut() {
            t(ev());
        }
    }

    /// Sends NMT start to `node` and waits the settle time, once per node.
    pub fn start_node(&mut self, node: NodeId) -> Result<(), SessionError> {
        if !self.nmt || self.started.contains(&node) {
            return Ok(());
        }
        let frame = transport::nmt_start(node);
        self.trace(|| TraceEvent::Sent(format!("{frame:<22} NMT start node {node}")));
        self.link.send(&frame)?;
        self.started.push(node);
        // The node takes no commands before it has settled; events it sends
        // meanwhile are kept.
        self.listen(Duration::from_millis(transport::START_DELAY_MS))
    }

    /// Sends `cmd` and waits for its answer. `Ok(None)`: the confirmation is
    /// switched off and no error came within the window. Reads are retried
    /// per the [`RetryPolicy`] and while the controller is busy; nothing else is.
    pub fn transact(&mut self, node: NodeId, address: Address, cmd: &Command) -> Result<Option<Answer>, SessionError> {
        let data = cmd.encode(address).map_err(|e| SessionError::Malformed {
            target: target(node, address),
            source: DecodeError::Malformed(format!("command not encodable: {e}")),
        })?;
        self.transact_data(node, address, &data)
    }

    /// As [`Self::transact`], for data bytes already encoded (and validated).
    pub fn transact_data(
        &mut self,
        node: NodeId,
        address: Address,
        data: &[u8; 8],
    ) -> Result<Option<Answer>, SessionError> {
        self.exchange(node, address, data, self.retry.read_retries)
    }

    /// One command with its answer; a read is repeated up to `read_retries`
    /// times after a timeout or a malformed answer.
    fn exchange(
        &mut self,
        node: NodeId,
        address: Address,
        data: &[u8; 8],
        read_retries: u32,
    ) -> Result<Option<Answer>, SessionError> {
        self.start_node(node)?;
        let def = table::command_for(data[0], data[2]);
        let read = def.is_some_and(|d| !d.reply.fields.is_empty());
        let attempts = if read { 1 + read_retries } else { 1 };
        let first = self.clock.now();
        let mut attempt = 0;
        loop {
            attempt += 1;
            let err = match self.attempt(node, address, data) {
                Ok(a) => return Ok(a),
                Err(Failure::Refused(e)) => {
                    let busy = matches!(e.general, GENERAL_INITIALISING | GENERAL_EEPROM_BUSY);
                    if read && busy && self.clock.now() + BUSY_RETRY_INTERVAL - first <= BUSY_RETRY_LIMIT {
                        self.trace(|| TraceEvent::Note(format!("controller busy, reading again: {}", e.describe())));
                        self.listen(BUSY_RETRY_INTERVAL)?;
                        attempt -= 1;
                        continue;
                    }
                    return Err(refused(node, address, data, &e));
                }
                Err(Failure::Session(e @ (SessionError::Timeout { .. } | SessionError::Malformed { .. }))) => e,
                Err(Failure::Session(e)) => return Err(e),
            };
            if attempt >= attempts {
                return Err(err);
            }
            self.trace(|| TraceEvent::Note(format!("retrying read ({attempt}/{})", attempts - 1)));
        }
    }

    fn attempt(&mut self, node: NodeId, address: Address, data: &[u8; 8]) -> Result<Option<Answer>, Failure> {
        // Answers queued before the command cannot answer it: a late reply to
        // an exchange that timed out would otherwise be taken for the reply to
        // the next command of the same kind (every later poll one behind).
        // Events among them are kept. Bounded, for a bus that never falls silent.
        for _ in 0..MAX_DRAIN {
            let Some(stale) = self.link.recv(Duration::ZERO)? else { break };
            if self.take_answer(&stale).is_some() {
                self.trace(|| TraceEvent::Received(format!("{stale:<22} ignored (queued before the command)")));
            }
        }
        let frame = transport::command_frame(node, data);
        self.trace(|| TraceEvent::Sent(format!("{frame:<22} {} to {}", describe(data), target(node, address))));
        self.link.send(&frame)?;
        let def = table::command_for(data[0], data[2]);
        let always = def.is_none_or(|d| d.confirm == Confirm::Always);
        let (timeout, need_reply) = if data[0] == table::STORE_CONFIGURATION {
            (self.timeout + STORE_TIME, true)
        } else if self.confirm || always {
            (self.timeout, true)
        } else {
            (self.timeout.min(NO_CONFIRM_WINDOW), false)
        };
        let deadline = self.clock.now() + timeout;
        loop {
            let now = self.clock.now();
            if now >= deadline {
                if need_reply {
                    let what = describe(data);
                    return Err(SessionError::Timeout { target: target(node, address), what, timeout }.into());
                }
                self.trace(|| TraceEvent::Note("no error within the window (confirmations are off)".into()));
                return Ok(None);
            }
            let Some(frame) = self.link.recv(deadline - now)? else { continue };
            let Some(answer) = self.take_answer(&frame) else { continue };
            if answer.node != node || Address::from_byte(answer.module) != address {
                self.trace(|| TraceEvent::Received(format!("{frame:<22} ignored (another node or module)")));
                continue;
            }
            match answer.kind {
                AnswerKind::Error if answer.command == data[0] => {
                    let e = ErrorReply::decode(&answer.data)
                        .map_err(|source| SessionError::Malformed { target: target(node, address), source })?;
                    self.trace(|| TraceEvent::Received(format!("{frame:<22} error: {}", e.describe())));
                    return Err(Failure::Refused(e));
                }
                AnswerKind::Reply if is_reply_to(&answer, data) => {
                    self.trace(|| TraceEvent::Received(format!("{frame:<22} {}", describe_answer(&answer))));
                    if def.is_some_and(|d| !d.reply.fields.is_empty()) {
                        if let Some(Err(source)) = answer.reply().map(|r| check_row(r, data)) {
                            return Err(SessionError::Malformed { target: target(node, address), source }.into());
                        }
                    }
                    return Ok(Some(answer));
                }
                _ => self.trace(|| TraceEvent::Received(format!("{frame:<22} ignored (answers another command)"))),
            }
        }
    }

    /// Classifies a received frame: events are queued (and `None` returned),
    /// other families' frames are ignored.
    fn take_answer(&mut self, frame: &CanFrame) -> Option<Answer> {
        let answer = match Answer::from_frame(frame) {
            Ok(Some(a)) => a,
            Ok(None) => {
                self.trace(|| TraceEvent::Received(format!("{frame:<22} ignored (not Cdios)")));
                return None;
            }
            Err(e) => {
                // Nothing on an answer id can be told apart without its code byte.
                self.trace(|| TraceEvent::Received(format!("{frame:<22} ignored ({e})")));
                return None;
            }
        };
        if answer.kind == AnswerKind::Event {
            self.trace(|| TraceEvent::Received(format!("{frame:<22} event: {}", describe_answer(&answer))));
            self.push_event(Event { at: self.clock.now(), answer });
            return None;
        }
        Some(answer)
    }

    fn push_event(&mut self, ev: Event) {
        if self.events.len() >= EVENT_QUEUE {
            self.events.pop_front();
            self.dropped_events += 1;
        }
        self.events.push_back(ev);
    }

    /// Receives for `d`, queueing events; anything else is ignored.
    pub fn listen(&mut self, d: Duration) -> Result<(), SessionError> {
        let deadline = self.clock.now() + d;
        loop {
            let now = self.clock.now();
            if now >= deadline {
                return Ok(());
            }
            match self.link.recv(deadline - now)? {
                Some(frame) => {
                    if self.take_answer(&frame).is_some() {
                        self.trace(|| TraceEvent::Received(format!("{frame:<22} ignored (no command pending)")));
                    }
                }
                None => return Ok(()),
            }
        }
    }

    /// The events received so far, oldest first.
    pub fn take_events(&mut self) -> Vec<Event> {
        self.events.drain(..).collect()
    }

    /// Events dropped because the queue was full.
    pub fn dropped_events(&self) -> u64 {
        self.dropped_events
    }

    /// A read: the reply decoded with the table.
    pub fn read(&mut self, node: NodeId, address: Address, cmd: &Command) -> Result<DecodedReply, SessionError> {
        let answer = self.transact(node, address, cmd)?;
        reply_of(node, address, answer)
    }

    /// Several reads of one module at once: one burst on the bus, the replies
    /// collected within one timeout (what a dashboard poll needs; on a slow
    /// link it saves a turnaround per read). Reads whose replies cannot be
    /// told apart, and any read the burst did not answer, go one at a time
    /// through [`Self::read`] with its retries.
    pub fn read_many(
        &mut self,
        node: NodeId,
        address: Address,
        cmds: &[Command],
    ) -> Result<Vec<DecodedReply>, SessionError> {
        let mut data = Vec::with_capacity(cmds.len());
        for cmd in cmds {
            data.push(cmd.encode(address).map_err(|e| SessionError::Malformed {
                target: target(node, address),
                source: DecodeError::Malformed(format!("command not encodable: {e}")),
            })?);
        }
        let distinct = data.iter().enumerate().all(|(i, a)| data[..i].iter().all(|b| !same_reply(a, b)));
        let mut got: Vec<Option<DecodedReply>> = vec![None; cmds.len()];
        if distinct && cmds.len() > 1 {
            self.start_node(node)?;
            for _ in 0..MAX_DRAIN {
                let Some(stale) = self.link.recv(Duration::ZERO)? else { break };
                if self.take_answer(&stale).is_some() {
                    self.trace(|| TraceEvent::Received(format!("{stale:<22} ignored (queued before the command)")));
                }
            }
            let frames: Vec<CanFrame> = data.iter().map(|d| transport::command_frame(node, d)).collect();
            for (f, d) in frames.iter().zip(&data) {
                self.trace(|| TraceEvent::Sent(format!("{f:<22} {} to {}", describe(d), target(node, address))));
            }
            self.link.send_many(&frames)?;
            let deadline = self.clock.now() + self.timeout;
            let mut pending = cmds.len();
            while pending > 0 {
                let now = self.clock.now();
                if now >= deadline {
                    break;
                }
                let Some(frame) = self.link.recv(deadline - now)? else { continue };
                let Some(answer) = self.take_answer(&frame) else { continue };
                if answer.node != node || Address::from_byte(answer.module) != address {
                    continue;
                }
                let slot = data.iter().position(|d| answer.kind == AnswerKind::Reply && is_reply_to(&answer, d));
                match (slot, answer.reply()) {
                    (Some(i), Some(Ok(r))) if got[i].is_none() && check_row(Ok(r.clone()), &data[i]).is_ok() => {
                        self.trace(|| TraceEvent::Received(format!("{frame:<22} {}", describe_answer(&answer))));
                        got[i] = Some(r);
                        pending -= 1;
                    }
                    // Errors and odd replies: left to the one-at-a-time path below.
                    _ => self.trace(|| TraceEvent::Received(format!("{frame:<22} left for a single read"))),
                }
            }
        }
        // The burst was the first attempt of every read it did not answer.
        let burst = distinct && cmds.len() > 1;
        let retries = self.retry.read_retries;
        let mut out = Vec::with_capacity(cmds.len());
        for (d, r) in data.iter().zip(got) {
            out.push(match r {
                Some(r) => r,
                None if !burst => reply_of(node, address, self.exchange(node, address, d, retries)?)?,
                None if retries == 0 => {
                    let (what, timeout) = (describe(d), self.timeout);
                    return Err(SessionError::Timeout { target: target(node, address), what, timeout });
                }
                None => reply_of(node, address, self.exchange(node, address, d, retries - 1)?)?,
            });
        }
        Ok(out)
    }

    /// 26h selector 0: the four status bytes, decoded.
    pub fn read_status(&mut self, node: NodeId, module: ModuleId) -> Result<StatusReport, SessionError> {
        let r = self.read(node, Address::Module(module), &Command::ReadStatus(StatusSelector::Status))?;
        let byte = |k| r.get(k).unwrap_or(0) as u8;
        Ok(decode_status([byte("status1"), byte("status2"), byte("status3"), byte("status4")]))
    }

    /// 26h selector 2: motor speed and RPM error.
    pub fn read_speed(&mut self, node: NodeId, module: ModuleId) -> Result<(i64, i64), SessionError> {
        let r = self.read(node, Address::Module(module), &Command::ReadStatus(StatusSelector::SpeedError))?;
        Ok((r.get("motor_speed").unwrap_or(0), r.get("rpm_error").unwrap_or(0)))
    }

    /// 21h: a position.
    pub fn read_position(
        &mut self,
        node: NodeId,
        module: ModuleId,
        source: PositionSource,
    ) -> Result<i32, SessionError> {
        let r = self.read(node, Address::Module(module), &Command::ReadPosition(source))?;
        Ok(r.get("position").unwrap_or(0) as i32)
    }
}

/// The decoded reply a read must have got.
fn reply_of(node: NodeId, address: Address, answer: Option<Answer>) -> Result<DecodedReply, SessionError> {
    let answer = answer.ok_or_else(|| SessionError::Malformed {
        target: target(node, address),
        source: DecodeError::Malformed("a read got no reply".into()),
    })?;
    match answer.reply() {
        Some(Ok(r)) => Ok(r),
        Some(Err(source)) => Err(SessionError::Malformed { target: target(node, address), source }),
        None => Err(SessionError::Malformed {
            target: target(node, address),
            source: DecodeError::Malformed("an error reply where a reply was expected".into()),
        }),
    }
}

/// `node 1 module 0` / `node 1 controller`.
pub fn target(node: NodeId, address: Address) -> String {
    match address {
        Address::Module(m) => format!("node {node} module {m}"),
        Address::Controller => format!("node {node} controller"),
    }
}

/// Whether the replies to two commands look alike (same reply code, and no
/// echoed selector to tell them apart).
fn same_reply(a: &[u8; 8], b: &[u8; 8]) -> bool {
    let (Some(da), Some(db)) = (table::command_for(a[0], a[2]), table::command_for(b[0], b[2])) else { return true };
    da.reply.code == db.reply.code && (da.reply.selector != ReplySelector::Echo || a[2] == b[2])
}

/// Whether `a` is the normal reply to the command `data`.
fn is_reply_to(a: &Answer, data: &[u8; 8]) -> bool {
    let Some(def) = table::command_for(data[0], data[2]) else { return a.data[0] == data[0] };
    a.data[0] == def.reply.code && (def.reply.selector != ReplySelector::Echo || a.data[2] == data[2])
}

/// A matched reply must decode with the row of the command it answers.
fn check_row(r: Result<DecodedReply, DecodeError>, data: &[u8; 8]) -> Result<(), DecodeError> {
    let r = r?;
    let want = table::command_for(data[0], data[2]).map(|d| d.key);
    let got = r.def.map(|d| d.key);
    // Set and read rows of one code share the reply code; a read is known by its fields.
    let same_layout = match (want.and_then(table::command), r.def) {
        (Some(w), Some(g)) => w.reply.fields == g.reply.fields,
        _ => false,
    };
    if same_layout {
        Ok(())
    } else {
        Err(DecodeError::Malformed(format!("reply decodes as {got:?}, expected {want:?}")))
    }
}

/// The Device error for an error reply: general error and status bits.
fn refused(node: NodeId, address: Address, data: &[u8; 8], e: &ErrorReply) -> SessionError {
    let mut parts = Vec::new();
    match e.general_error() {
        Some((name, text)) if e.general != 0 => parts.push(format!("general error {} {name} ({text})", e.general)),
        None => parts.push(format!("general error {} (not in the table)", e.general)),
        _ => {}
    }
    parts.extend(e.flags().iter().map(|f| format!("{} ({})", f.name, f.meaning)));
    parts.extend(e.unknown_bits().iter().map(|(s, b)| format!("error status {s} bit {b}")));
    if parts.is_empty() {
        parts.push("an error reply with no error bits set".into());
    }
    SessionError::Device { target: target(node, address), what: describe(data), reason: parts.join(", ") }
}

/// `goto absolute position=5000`: the table row, selector and fields of command bytes.
pub fn describe(data: &[u8; 8]) -> String {
    match table::decode_command(data) {
        Ok(d) => {
            let sel = d.def.selector(d.selector).map(|s| s.key).filter(|k| *k != "none");
            let mut s = d.def.key.to_string();
            if let Some(k) = sel {
                s.push(' ');
                s.push_str(k);
            }
            for f in d.fields.iter().filter(|f| !f.key.starts_with("key_")) {
                s.push_str(&format!(" {}={}", f.key, f.raw));
            }
            s
        }
        Err(_) => format!("command {:02x?}", data),
    }
}

/// A reply or event for humans: `read_position current position=-1200`.
pub fn describe_answer(a: &Answer) -> String {
    match a.reply() {
        Some(Ok(r)) => {
            let kind = if a.kind == AnswerKind::Event { "event " } else { "" };
            let mut s = format!("{kind}{}", r.def.map_or("unknown", |d| d.key));
            for f in &r.fields {
                s.push_str(&format!(" {}={}", f.key, f.raw));
            }
            s
        }
        _ => match a.error() {
            Some(e) => e.describe(),
            None => format!("{:02x?}", a.data),
        },
    }
}

#[cfg(test)]
mod tests;
