//! The Cdios session: commands to `0x200 + node`, answers from `0x180 + node`
//! (specs README, "Cdios 6168"), one command at a time, or reads of one
//! module as one burst ([`Cdios::read_many`]). A burst may be sent
//! ([`Cdios::send_many`]) and collected later ([`Cdios::collect_many`]),
//! with other commands in between: every reply read, whoever reads it, is
//! offered first to the bursts still waiting, oldest first; a burst nobody
//! collects ([`Cdios::abandon_many`]) keeps taking its replies until its
//! deadline, so none is taken for the reply of a later command.
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
use std::ops::ControlFlow;
use std::time::{Duration, Instant};

use super::core::{core_setters, with_read_retries, Core, Retryable};
use super::{SessionError, TraceEvent};
use crate::link::CanLink;
use crate::proto::cdios::session::{incoming, is_busy, Burst, Exchange, Incoming, Settled, Verdict};
use crate::proto::cdios::table::DecodedReply;
use crate::proto::cdios::transport::{self, Answer};
use crate::proto::cdios::{
    decode_status, Address, Command, ErrorReply, ModuleId, NodeId, PositionSource, StatusReport, StatusSelector,
};
use crate::proto::{CanFrame, DecodeError};

pub use crate::proto::cdios::session::{NO_CONFIRM_WINDOW, STORE_TIME};

/// Default answer timeout on CAN (as for PowerCube).
pub const TIMEOUT: Duration = Duration::from_millis(100);
/// A read refused because the controller is busy is tried again after this...
pub const BUSY_RETRY_INTERVAL: Duration = Duration::from_millis(50);
/// ...until this much time has passed (longer than an EEPROM write and the
/// 500 ms of initialisation).
pub const BUSY_RETRY_LIMIT: Duration = Duration::from_millis(1000);
/// Events kept for the caller; older ones are dropped (and counted).
pub const EVENT_QUEUE: usize = 1024;

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

impl Retryable for Failure {
    fn retryable(&self) -> bool {
        matches!(self, Self::Session(e) if e.retryable())
    }
}

/// Events received and not taken yet, and the bursts of reads still
/// awaiting replies: every answer read, whoever reads it, is offered to
/// them first, oldest first ([`Cdios::send_many`]).
#[derive(Default)]
struct Events {
    queue: VecDeque<Event>,
    dropped: u64,
    in_flight: VecDeque<InFlight>,
    next_burst: u64,
}

/// A burst of reads sent and not collected yet.
struct InFlight {
    id: u64,
    burst: Burst,
    /// It takes replies until then.
    deadline: Instant,
    /// Nobody will collect it: it only keeps its late replies from being
    /// taken for the replies of later commands.
    abandoned: bool,
}

/// What a received frame was.
enum Sorted {
    /// An answer no burst in flight took.
    Answer(Answer),
    /// A reply a burst in flight took (the burst's id).
    Settled(u64),
    /// An event, another family's frame, something undecodable.
    Other,
}

impl Events {
    fn push(&mut self, ev: Event) {
        if self.queue.len() >= EVENT_QUEUE {
            self.queue.pop_front();
            self.dropped += 1;
        }
        self.queue.push_back(ev);
    }

    /// Sorts a received frame: events are queued (and `None` returned),
    /// other families' frames are ignored, replies a burst in flight takes
    /// go to it, other answers come back.
    fn take_answer(&mut self, core: &mut Core, frame: &CanFrame) -> Option<Answer> {
        match self.sort(core, frame) {
            Sorted::Answer(a) => Some(a),
            Sorted::Settled(_) | Sorted::Other => None,
        }
    }

    fn sort(&mut self, core: &mut Core, frame: &CanFrame) -> Sorted {
        match incoming(frame) {
            Incoming::Foreign => core.trace(|| TraceEvent::Received(format!("{frame:<22} ignored (not Cdios)"))),
            // Nothing on an answer id can be told apart without its code byte.
            Incoming::Undecodable(e) => core.trace(|| TraceEvent::Received(format!("{frame:<22} ignored ({e})"))),
            Incoming::Event(answer) => {
                core.trace(|| TraceEvent::Received(format!("{frame:<22} event: {answer}")));
                self.push(Event { at: core.now(), answer });
            }
            Incoming::Answer(answer) => {
                let now = core.now();
                let live = self.in_flight.iter_mut().filter(|b| b.burst.pending() > 0 && now < b.deadline);
                for b in live {
                    if let Settled::Read(_) = b.burst.handle(&answer) {
                        let note = if b.abandoned { " (to an abandoned burst)" } else { "" };
                        core.trace(|| TraceEvent::Received(format!("{frame:<22} {answer}{note}")));
                        return Sorted::Settled(b.id);
                    }
                }
                return Sorted::Answer(answer);
            }
        }
        Sorted::Other
    }

    /// Drops the answers queued before a command (events among them are kept).
    fn drain(&mut self, core: &mut Core, link: &mut dyn CanLink) -> Result<(), crate::link::LinkError> {
        core.drain(link, |core, stale| {
            if self.take_answer(core, &stale).is_some() {
                core.trace(|| TraceEvent::Received(format!("{stale:<22} ignored (queued before the command)")));
            }
        })
    }
}

pub struct Cdios {
    link: Box<dyn CanLink>,
    core: Core,
    nmt: bool,
    started: Vec<NodeId>,
    confirm: bool,
    events: Events,
}

core_setters!(Cdios, timeout);

impl Cdios {
    pub fn new(link: Box<dyn CanLink>) -> Self {
        Self {
            link,
            core: Core::new(TIMEOUT),
            nmt: true,
            started: Vec::new(),
            confirm: true,
            events: Events::default(),
        }
    }

    /// `false`: the nodes are operational already; no NMT start is sent.
    pub fn set_nmt(&mut self, nmt: bool) {
        self.nmt = nmt;
    }

    /// `false`: the controller's 'Confirm' is 0, confirmations are not sent.
    pub fn set_confirm(&mut self, confirm: bool) {
        self.confirm = confirm;
    }

    /// Sends NMT start to `node` and waits the settle time, once per node.
    pub fn start_node(&mut self, node: NodeId) -> Result<(), SessionError> {
        if !self.needs_start(node) {
            return Ok(());
        }
        self.send_start(node)
    }

    /// Whether the next command to `node` would go after an NMT start.
    pub fn needs_start(&self, node: NodeId) -> bool {
        self.nmt && !self.started.contains(&node)
    }

    /// `node` answered, so it runs: no NMT start goes to it.
    pub fn mark_running(&mut self, node: NodeId) {
        if !self.started.contains(&node) {
            self.started.push(node);
        }
    }

    /// `node` did not answer after all: the next command starts it again.
    pub fn forget_running(&mut self, node: NodeId) {
        self.started.retain(|n| *n != node);
    }

    /// NMT start to `node` and its settle time, whatever was sent before
    /// (a node that stopped answering may have been stopped or reset).
    pub fn send_start(&mut self, node: NodeId) -> Result<(), SessionError> {
        let frame = transport::nmt_start(node);
        self.core.trace(|| TraceEvent::Sent(format!("{frame:<22} NMT start node {node}")));
        self.link.send(&frame)?;
        self.mark_running(node);
        // The node takes no commands before it has settled; events it sends
        // meanwhile are kept.
        self.listen(Duration::from_millis(transport::START_DELAY_MS))
    }

    /// Sends `cmd` and waits for its answer. `Ok(None)`: the confirmation is
    /// switched off and no error came within the window. Reads are retried
    /// per the [`RetryPolicy`](super::RetryPolicy) and while the controller
    /// is busy; nothing else is.
    pub fn transact(&mut self, node: NodeId, address: Address, cmd: &Command) -> Result<Option<Answer>, SessionError> {
        let data = encode(node, address, cmd)?;
        self.transact_data(node, address, &data)
    }

    /// As [`Self::transact`], for data bytes already encoded (and validated).
    pub fn transact_data(
        &mut self,
        node: NodeId,
        address: Address,
        data: &[u8; 8],
    ) -> Result<Option<Answer>, SessionError> {
        self.exchange(Exchange::new(node, address, *data), None)
    }

    /// One command with its answer; a read is repeated per the retry policy
    /// after a timeout or a malformed answer (`failed`: its first attempt
    /// went out in a burst and failed so).
    fn exchange(&mut self, ex: Exchange, failed: Option<SessionError>) -> Result<Option<Answer>, SessionError> {
        self.start_node(ex.node)?;
        let first = self.core.now();
        let r =
            with_read_retries(self, ex.is_read(), failed.map(Failure::Session), |s| s.attempt_while_busy(&ex, first));
        r.map_err(|f| match f {
            Failure::Session(e) => e,
            Failure::Refused(e) => refused(&ex, &e),
        })
    }

    /// One attempt; a read the controller refuses as busy is sent again
    /// after a pause, within [`BUSY_RETRY_LIMIT`] from `first`.
    fn attempt_while_busy(&mut self, ex: &Exchange, first: Instant) -> Result<Option<Answer>, Failure> {
        loop {
            match self.attempt(ex) {
                Err(Failure::Refused(e))
                    if ex.is_read()
                        && is_busy(&e)
                        && self.core.now() + BUSY_RETRY_INTERVAL - first <= BUSY_RETRY_LIMIT =>
                {
                    self.core.trace(|| TraceEvent::Note(format!("controller busy, reading again: {}", e.describe())));
                    self.listen(BUSY_RETRY_INTERVAL)?;
                }
                other => return other,
            }
        }
    }

    fn attempt(&mut self, ex: &Exchange) -> Result<Option<Answer>, Failure> {
        let Self { link, core, events, .. } = self;
        events.drain(core, &mut **link)?;
        let frame = ex.frame();
        core.trace(|| TraceEvent::Sent(format!("{frame:<22} {ex} to {}", target(ex.node, ex.address))));
        link.send(&frame)?;
        let wait = ex.wait(core.timeout, self.confirm);
        let deadline = core.now() + wait.timeout;
        let answer = core.recv_until(&mut **link, deadline, |core, frame| {
            let Some(answer) = events.take_answer(core, &frame) else { return ControlFlow::Continue(()) };
            let verdict = ex.handle(&answer);
            core.trace(|| {
                TraceEvent::Received(match &verdict {
                    Verdict::OtherTarget => format!("{frame:<22} ignored (another node or module)"),
                    Verdict::OtherCommand => format!("{frame:<22} ignored (answers another command)"),
                    Verdict::Refused(e) => format!("{frame:<22} error: {}", e.describe()),
                    Verdict::Malformed(_) | Verdict::Reply => format!("{frame:<22} {answer}"),
                })
            });
            match verdict {
                Verdict::OtherTarget | Verdict::OtherCommand => ControlFlow::Continue(()),
                Verdict::Refused(e) => ControlFlow::Break(Err(Failure::Refused(e))),
                Verdict::Malformed(source) => {
                    let e = SessionError::Malformed { target: target(ex.node, ex.address), source };
                    ControlFlow::Break(Err(e.into()))
                }
                Verdict::Reply => ControlFlow::Break(Ok(Some(answer))),
            }
        })?;
        if let Some(r) = answer {
            return r;
        }
        if wait.need_reply {
            let (what, timeout) = (ex.to_string(), wait.timeout);
            return Err(SessionError::Timeout { target: target(ex.node, ex.address), what, timeout }.into());
        }
        core.trace(|| TraceEvent::Note("no error within the window (confirmations are off)".into()));
        Ok(None)
    }

    /// Receives for `d`, queueing events; anything else is ignored.
    pub fn listen(&mut self, d: Duration) -> Result<(), SessionError> {
        let Self { link, core, events, .. } = self;
        let deadline = core.now() + d;
        core.recv_until(&mut **link, deadline, |core, frame| {
            if events.take_answer(core, &frame).is_some() {
                core.trace(|| TraceEvent::Received(format!("{frame:<22} ignored (no command pending)")));
            }
            ControlFlow::<()>::Continue(())
        })?;
        Ok(())
    }

    /// The events received so far, oldest first.
    pub fn take_events(&mut self) -> Vec<Event> {
        self.events.queue.drain(..).collect()
    }

    /// Events dropped because the queue was full.
    pub fn dropped_events(&self) -> u64 {
        self.events.dropped
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
        let sent = self.send_many(node, address, cmds)?;
        self.collect_many(sent)
    }

    /// The send half of [`Self::read_many`]: the burst goes out and its
    /// replies are left for [`Self::collect_many`]; other commands (another
    /// module's burst, an action) may go out meanwhile, and each reply is
    /// offered to the oldest burst still waiting first. Reads that cannot go
    /// as one burst are all sent by the collect, one at a time.
    pub fn send_many(&mut self, node: NodeId, address: Address, cmds: &[Command]) -> Result<SentReads, SessionError> {
        let data = cmds.iter().map(|cmd| encode(node, address, cmd)).collect::<Result<Vec<_>, _>>()?;
        if !Burst::pipelinable(&data) {
            return Ok(SentReads { node, address, data, id: None });
        }
        self.start_node(node)?;
        let Self { link, core, events, .. } = self;
        let now = core.now();
        events.in_flight.retain(|b| !(b.abandoned && (b.burst.pending() == 0 || now >= b.deadline)));
        events.drain(core, &mut **link)?;
        let burst = Burst::new(node, address, &data);
        let frames: Vec<CanFrame> = burst.frames().collect();
        for (f, d) in frames.iter().zip(&data) {
            let ex = Exchange::new(node, address, *d);
            core.trace(|| TraceEvent::Sent(format!("{f:<22} {ex} to {}", target(node, address))));
        }
        let deadline = core.send_burst(&mut **link, &frames)?;
        let id = events.next_burst;
        events.next_burst += 1;
        events.in_flight.push_back(InFlight { id, burst, deadline, abandoned: false });
        Ok(SentReads { node, address, data, id: Some(id) })
    }

    /// The replies of reads sent with [`Self::send_many`], in command order.
    pub fn collect_many(&mut self, sent: SentReads) -> Result<Vec<DecodedReply>, SessionError> {
        let SentReads { node, address, data, id } = sent;
        let got = match id {
            Some(id) => self.collect_burst(id)?,
            None => vec![None; data.len()],
        };
        let mut out = Vec::with_capacity(data.len());
        for (d, r) in data.iter().zip(got) {
            let ex = Exchange::new(node, address, *d);
            out.push(match r {
                Some(r) => r,
                // The burst was the first attempt of every read it did not answer.
                None if id.is_some() => {
                    let (what, timeout) = (ex.to_string(), self.core.timeout);
                    let first = SessionError::Timeout { target: target(node, address), what, timeout };
                    reply_of(node, address, self.exchange(ex, Some(first))?)?
                }
                None => reply_of(node, address, self.exchange(ex, None)?)?,
            });
        }
        Ok(out)
    }

    /// Gives up reads sent with [`Self::send_many`] without waiting: their
    /// replies are taken (and dropped) as they come, up to the burst's deadline.
    pub fn abandon_many(&mut self, sent: SentReads) {
        if let Some(b) = sent.id.and_then(|id| self.events.in_flight.iter_mut().find(|b| b.id == id)) {
            b.abandoned = true;
        }
    }

    fn collect_burst(&mut self, id: u64) -> Result<Vec<Option<DecodedReply>>, SessionError> {
        let Self { link, core, events, .. } = self;
        let at = events.in_flight.iter().position(|b| b.id == id).expect("a burst is collected once");
        let (deadline, pending) = (events.in_flight[at].deadline, events.in_flight[at].burst.pending());
        let received = core.collect(&mut **link, deadline, pending, |core, frame| match events.sort(core, &frame) {
            Sorted::Settled(settled) => settled == id,
            // Errors and odd replies: left to the one-at-a-time path.
            Sorted::Answer(answer) => {
                core.trace(|| {
                    TraceEvent::Received(format!("{frame:<22} {answer} not awaited here (left for a single read)"))
                });
                false
            }
            Sorted::Other => false,
        });
        let at = events.in_flight.iter().position(|b| b.id == id).expect("found above");
        let done = events.in_flight.remove(at).expect("found above");
        received?;
        Ok(done.burst.into_replies())
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

/// Reads sent with [`Cdios::send_many`], to hand to [`Cdios::collect_many`]
/// or [`Cdios::abandon_many`].
#[derive(Debug)]
#[must_use = "reads sent are collected or abandoned"]
pub struct SentReads {
    node: NodeId,
    address: Address,
    data: Vec<[u8; 8]>,
    /// The burst in flight; `None`: the reads go one at a time at the collect.
    id: Option<u64>,
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

/// The command bytes, or why they cannot be sent.
fn encode(node: NodeId, address: Address, cmd: &Command) -> Result<[u8; 8], SessionError> {
    cmd.encode(address).map_err(|e| SessionError::Malformed {
        target: target(node, address),
        source: DecodeError::Malformed(format!("command not encodable: {e}")),
    })
}

/// The Device error for an error reply: general error and status bits.
fn refused(ex: &Exchange, e: &ErrorReply) -> SessionError {
    SessionError::refused(target(ex.node, ex.address), ex.to_string(), e.into())
}

#[cfg(test)]
mod tests;
