//! The PA-CONTROL session: one command, its acknowledge, and the polls a
//! command with BE = 0 needs, over a serial [`ByteLink`] (manual 3.3).
//!
//! - The line is half-duplex and acknowledges do not name the command they
//!   answer, so stale input is dropped before each command and the first
//!   acknowledge after it that can answer it ([`Transaction::could_answer`]:
//!   the command's data type) is taken as its answer. A new session looks
//!   for input already pending (the last client may have been killed with an
//!   answer on its way) and, only if there is some, waits for the line to
//!   fall quiet for an answer timeout, dropping what arrives: a one-shot
//!   command on a clean line costs no wait. After a skipped stale
//!   acknowledge the session always waits for quiet before the next request,
//!   so a late answer cannot shift every later exchange by one.
//! - A request (or poll) that timed out is still owed its answer: a slow
//!   controller or line delivers it late, and taken by the next request it
//!   would shift every later exchange by one (a late 190B taken for the end
//!   of 0A84, a late "in position" for this poll's). Its type cannot tell it
//!   apart when both are integers or both floats, so before anything else
//!   is sent (the retry of a read, a stop, a poll) the session waits for
//!   every owed answer and drops it, up to [`MAX_LATE`] after the timeout;
//!   one later than that is taken as lost. The session also waits for them
//!   when it is dropped, so the next client does not inherit them. Since a
//!   late answer holds the line anyway, a poll's answer (and, under
//!   [`Pac::patiently`], every answer of a stop) is awaited up to
//!   [`MAX_LATE`] beyond the timeout and taken. A line on which nothing at
//!   all came for that long is silent, not late: until a byte comes, its
//!   timeouts are not waited out (a halt-all must reach the other devices).
//! - While an acknowledge says BE = 0 the session polls with a lone EOT every
//!   [`Pac::set_poll_interval`] until BE = 1 or the overall busy timeout
//!   ([`Pac::set_busy_timeout`], generous by default: moves and reference
//!   drives take minutes).
//! - While a command is unfinished (0A87 / 0A89 / 0A84 / 0A93 answering
//!   BE = 0) nothing but polls is sent: [`Pac::transact`] refuses with
//!   [`PacError::Busy`] (the rule of manual 5.2.6.6, enforced with
//!   [`Transaction::allows`]). The one way past it is
//!   [`Pac::abandon_and_stop`], for Ctrl-C during a wait.
//! - The live position of a 0A87 / 0A89 move is the Q_PAR of each poll's
//!   acknowledge (manual 3.4.3); the observer passed to
//!   [`Pac::transact_with`] sees every acknowledge between polls. Moves that
//!   must stay interruptible use 0A94 / 0A95 instead and read 190C / 1910
//!   (the line stays free for a stop): see `pac-move --wait`.
//! - QUIT != 0 is [`SessionError::Device`] with the manual 6.5 number, hex and
//!   decimal, and its text.
//! - Reads (every 1xxx code: get / send) are retried per the [`RetryPolicy`](super::RetryPolicy);
//!   nothing else is, least of all motion.
//! - CHECK is sent per [`CheckRule::Strict`] unless told to include ETX;
//!   acknowledges are accepted under either rule and the trace says which.

use std::ops::ControlFlow;
use std::time::{Duration, Instant};

use super::core::{core_setters, with_read_retries, Core, Retryable};
use super::{SessionError, TraceEvent};
use crate::link::{ByteLink, SerialFormat};
use crate::proto::pac::frame::{EncodeOptions, FrameError};
use crate::proto::pac::session::{Outgoing, Step, Transaction, TransactionError, DEFAULT_POLL_INTERVAL};
use crate::proto::pac::{printable, Ack, AckDecoder, CheckRule, Command};
use crate::proto::DecodeError;

/// Base answer timeout before wire time is added (as for PowerCube RS232;
/// the controller answers within its < 10 ms action loop, manual 2.3.4).
pub const BASE_TIMEOUT: Duration = Duration::from_millis(30);
/// Longest acknowledge we budget wire time for: SOH STX, six fields with a
/// float of 10 integer digits and 4 decimals, ETX, 3 CHECK digits, EOT.
const MAX_ACK_CHARS: u32 = 48;
/// The shortest acknowledge: SOH STX `0;1;1;0;0;0` ETX, one CHECK digit, EOT.
const MIN_ACK_CHARS: usize = 16;
/// Overall limit for a command answering BE = 0 (moves, reference drives).
pub const DEFAULT_BUSY_TIMEOUT: Duration = Duration::from_secs(600);

/// Who the errors name.
const TARGET: &str = "PA-CONTROL";

/// What went wrong in a PA-CONTROL exchange.
#[derive(Debug, thiserror::Error)]
pub enum PacError {
    #[error(transparent)]
    Session(#[from] SessionError),
    /// Refused locally: an earlier command is unfinished and only polls may
    /// be sent (manual 5.2.6.6). Nothing was sent.
    #[error("command {busy:04X} is still being processed (BE = 0): only polls may be sent until it ends, so {refused:04X} was not sent")]
    Busy { busy: u16, refused: u16 },
    /// The observer asked to stop waiting; the command is still unfinished
    /// on the controller (see [`Pac::abandon_and_stop`]).
    #[error("stopped waiting for {code:04X} after {polls} poll(s)")]
    Abandoned { code: u16, polls: u32, last: Ack },
    /// The command could not be written (a non-finite PAR_2).
    #[error("cannot encode the command: {0}")]
    Encode(String),
    /// A poll without an unfinished command: nothing was sent.
    #[error("no command is being processed: there is nothing to poll")]
    NotBusy,
}

impl PacError {
    pub fn kind(&self) -> super::ErrorKind {
        match self {
            Self::Session(e) => e.kind(),
            Self::Busy { .. } | Self::Encode(_) | Self::NotBusy => super::ErrorKind::Usage,
            Self::Abandoned { .. } => super::ErrorKind::Interrupted,
        }
    }
}

/// What the observer of [`Pac::transact_with`] sees after each acknowledge.
#[derive(Debug, Clone, Copy)]
pub struct Progress {
    pub command: Command,
    pub ack: Ack,
    /// Polls sent so far.
    pub polls: u32,
    pub elapsed: Duration,
}

/// The final acknowledge of a command and what it took.
#[derive(Debug, Clone, Copy)]
pub struct Done {
    pub ack: Ack,
    pub polls: u32,
    pub elapsed: Duration,
}

pub struct Pac {
    link: Box<dyn ByteLink>,
    decoder: AckDecoder,
    options: EncodeOptions,
    bits_per_char: u32,
    baud: u32,
    timeout: Option<Duration>,
    poll_interval: Duration,
    busy_timeout: Duration,
    core: Core,
    /// A command left unfinished (BE = 0) by an abandoned wait or [`Pac::start`].
    busy: Option<Transaction>,
    last_status: Option<u16>,
    last_ack: Option<Ack>,
    last_quit: Option<u16>,
    last_check: Option<CheckRule>,
    /// What is known about older answers still on the line ([`Pac::settle`]).
    line: Line,
    /// Answers owed to requests and polls that timed out, and until when
    /// they are waited for ([`Pac::await_owed`]).
    owed: u32,
    owed_until: Option<Instant>,
    /// Answers are awaited [`MAX_LATE`] longer ([`Pac::patiently`]).
    patient: bool,
    /// Nothing at all came for an answer timeout plus [`MAX_LATE`]: the
    /// controller does not answer (unplugged, off), it is not late. Until a
    /// byte comes, timeouts are not waited out: a halt of other devices
    /// after this one's must not wait for answers that never come.
    silent: bool,
}

/// What the session knows about answers to older exchanges on the line.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Line {
    /// Nothing of an older exchange can still arrive.
    Quiet,
    /// A new session: an answer to a killed client may be arriving. Input
    /// already pending says so; a clean line costs no wait.
    Unchecked,
    /// A stale acknowledge was seen: more may follow, wait for quiet.
    Suspect,
}

/// Longest wait for a quiet line: a line that never falls quiet is not
/// waited out for ever, the answer check still guards the exchange.
const MAX_SETTLE: Duration = Duration::from_secs(1);

/// How long after its timeout an answer is still waited for before the
/// next request: one later than this is taken as lost.
pub const MAX_LATE: Duration = Duration::from_millis(500);

/// Every read code is 1xxx (get / send, manual 5.1); writes and actions are 0xxx.
pub fn is_read(code: u16) -> bool {
    code >> 12 == 1
}

core_setters!(Pac);

impl Retryable for PacError {
    fn retryable(&self) -> bool {
        matches!(self, Self::Session(e) if e.retryable())
    }
}

impl Pac {
    /// `baud` and `format` set the default timeout (30 ms plus wire time).
    pub fn new(link: Box<dyn ByteLink>, baud: u32, format: SerialFormat) -> Self {
        Self {
            link,
            decoder: AckDecoder::new(),
            options: EncodeOptions::default(),
            bits_per_char: format.bits_per_char(),
            baud: baud.max(1),
            timeout: None,
            poll_interval: DEFAULT_POLL_INTERVAL,
            busy_timeout: DEFAULT_BUSY_TIMEOUT,
            core: Core::new(BASE_TIMEOUT),
            busy: None,
            last_status: None,
            last_ack: None,
            last_quit: None,
            last_check: None,
            line: Line::Unchecked,
            owed: 0,
            owed_until: None,
            patient: false,
            silent: false,
        }
    }

    /// A fixed answer timeout instead of 30 ms plus wire time.
    pub fn set_timeout(&mut self, timeout: Duration) {
        self.timeout = Some(timeout);
    }

    pub fn set_poll_interval(&mut self, interval: Duration) {
        self.poll_interval = interval;
    }

    pub fn poll_interval(&self) -> Duration {
        self.poll_interval
    }

    /// Overall limit for a command that answers BE = 0.
    pub fn set_busy_timeout(&mut self, timeout: Duration) {
        self.busy_timeout = timeout;
    }

    /// Which rule the CHECK of sent commands follows (received ones may
    /// follow either).
    pub fn set_check_rule(&mut self, rule: CheckRule) {
        self.options.check_rule = rule;
    }

    /// STATUS of the latest acknowledge.
    /// The last acknowledge received, whole: what a command that went
    /// through the device face reports of the controller's answer.
    pub fn last_ack(&self) -> Option<Ack> {
        self.last_ack
    }

    pub fn last_status(&self) -> Option<u16> {
        self.last_status
    }

    /// QUIT of the latest acknowledge (0: accepted).
    pub fn last_quit(&self) -> Option<u16> {
        self.last_quit
    }

    /// The CHECK rule the latest acknowledge matched.
    pub fn last_check_rule(&self) -> Option<CheckRule> {
        self.last_check
    }

    /// The unfinished command, if one answered BE = 0 and was not seen to its end.
    pub fn busy_command(&self) -> Option<&Command> {
        self.busy.as_ref().map(Transaction::command)
    }

    /// The answer timeout for a frame of `request_len` characters.
    pub fn answer_timeout(&self, request_len: usize) -> Duration {
        self.timeout.unwrap_or_else(|| {
            let chars = request_len as u64 + u64::from(MAX_ACK_CHARS);
            BASE_TIMEOUT
                + Duration::from_micros(chars * u64::from(self.bits_per_char) * 1_000_000 / u64::from(self.baud))
        })
    }

    /// Runs `f` with every answer awaited up to [`MAX_LATE`] beyond the
    /// answer timeout: for the stop of last resort, whose answer, were it
    /// late, would hold the line that long anyway ([`Pac::settle`]), and
    /// which is better taken than given up on a slow line.
    pub fn patiently<T>(&mut self, f: impl FnOnce(&mut Self) -> T) -> T {
        let was = std::mem::replace(&mut self.patient, true);
        let out = f(self);
        self.patient = was;
        out
    }

    /// Sends `cmd` and waits until it is finished (BE = 1), polling while
    /// BE = 0. Reads are retried; nothing else is.
    pub fn transact(&mut self, cmd: &Command) -> Result<Done, PacError> {
        self.transact_with(cmd, &mut |_| true)
    }

    /// As [`transact`](Self::transact); `observe` sees every acknowledge and
    /// returns `false` to stop waiting ([`PacError::Abandoned`]; the command
    /// stays unfinished on the controller and in this session).
    pub fn transact_with(
        &mut self,
        cmd: &Command,
        observe: &mut dyn FnMut(&Progress) -> bool,
    ) -> Result<Done, PacError> {
        with_read_retries(self, is_read(cmd.code), None, |s| s.run(cmd, observe))
    }

    /// Sends `cmd` and returns its first acknowledge. If that says BE = 0 the
    /// command stays unfinished: [`poll`](Self::poll) follows it, any other
    /// command is refused. Never retried.
    pub fn start(&mut self, cmd: &Command) -> Result<Step, PacError> {
        let mut t = self.begin(cmd)?;
        let ack = self.await_ack(&t)?;
        let step = self.handle(&mut t, ack)?;
        if let Step::NeedPoll { .. } = step {
            self.busy = Some(t);
        }
        Ok(step)
    }

    /// Polls the unfinished command once (EOT) and returns the fresh acknowledge.
    pub fn poll(&mut self) -> Result<Step, PacError> {
        let Some(mut t) = self.busy.take() else { return Err(PacError::NotBusy) };
        let ack = match self.send_poll(&mut t) {
            Ok(ack) => ack,
            Err(e) => {
                // Unanswered, the command still runs as far as anyone knows.
                self.busy = Some(t);
                return Err(e);
            }
        };
        let step = self.handle(&mut t, ack)?;
        if let Step::NeedPoll { .. } = step {
            self.busy = Some(t);
        }
        Ok(step)
    }

    /// Ctrl-C while a command is unfinished: gives up its acknowledge and
    /// sends `stop` anyway (0A93 abort-move-axis, polled to standstill).
    /// This is the one deliberate exception to "only polls while BE = 0":
    /// the rule keeps the master from losing the running command's answer,
    /// and here losing it is the point. Without an unfinished command it is
    /// an ordinary [`transact`](Self::transact).
    pub fn abandon_and_stop(&mut self, stop: &Command) -> Result<Done, PacError> {
        if let Some(t) = self.busy.take() {
            let code = t.command().code;
            self.core.trace(|| TraceEvent::Note(format!("abandoning unfinished {code:04X} to send {:04X}", stop.code)));
        }
        self.transact(stop)
    }

    fn begin(&mut self, cmd: &Command) -> Result<Transaction, PacError> {
        if let Some(t) = &self.busy {
            if !t.allows(Outgoing::Command(cmd)) {
                return Err(PacError::Busy { busy: t.command().code, refused: cmd.code });
            }
        }
        let t = Transaction::with_options(*cmd, self.options).poll_interval(self.poll_interval);
        let bytes = t.request().map_err(|e| PacError::Encode(e.to_string()))?;
        // Half-duplex: anything still buffered belongs to an older exchange.
        self.settle()?;
        self.core.trace(|| TraceEvent::Sent(format!("{}  {cmd}", printable(&bytes))));
        self.link.clear_input().map_err(SessionError::from)?;
        self.decoder.clear();
        self.link.write_all(&bytes).map_err(SessionError::from)?;
        Ok(t)
    }

    fn send_poll(&mut self, t: &mut Transaction) -> Result<Ack, PacError> {
        let bytes = t.poll();
        let polls = t.polls();
        self.settle()?;
        self.core.trace(|| TraceEvent::Sent(format!("{}  poll {polls}", printable(&bytes))));
        self.link.clear_input().map_err(SessionError::from)?;
        self.decoder.clear();
        self.link.write_all(&bytes).map_err(SessionError::from)?;
        self.await_ack(t)
    }

    /// Unless the line is known to be quiet, reads and drops input until
    /// nothing has come for an answer timeout (at most [`MAX_SETTLE`]): an
    /// answer still on its way is not yet in the buffer that clearing the
    /// input empties. A new session waits only if input is already pending.
    fn settle(&mut self) -> Result<(), PacError> {
        self.await_owed()?;
        let mut dropped = 0usize;
        match self.line {
            Line::Quiet => return Ok(()),
            Line::Unchecked => {
                let mut buf = [0u8; 128];
                dropped = self.link.read(&mut buf, Duration::ZERO).map_err(SessionError::from)?;
            }
            Line::Suspect => {}
        }
        if self.line == Line::Suspect || dropped > 0 {
            let quiet = self.answer_timeout(MAX_ACK_CHARS as usize);
            let Self { link, core, .. } = self;
            let limit = core.now() + MAX_SETTLE;
            core.read_until(&mut **link, (core.now() + quiet).min(limit), |core, chunk, deadline| {
                if !chunk.is_empty() {
                    dropped += chunk.len();
                    *deadline = (core.now() + quiet).min(limit);
                }
                ControlFlow::<()>::Continue(())
            })
            .map_err(SessionError::from)?;
        }
        if dropped > 0 {
            self.core.trace(|| TraceEvent::Note(format!("dropped {dropped} stale byte(s) before the request")));
        }
        self.line = Line::Quiet;
        Ok(())
    }

    /// Reads and drops the answers owed to requests that timed out, until
    /// all have come or [`MAX_LATE`] after the last timeout. A garbled frame
    /// counts as one: it was an answer.
    fn await_owed(&mut self) -> Result<(), PacError> {
        let (owed, Some(until)) = (self.owed, self.owed_until) else { return Ok(()) };
        if owed == 0 {
            return Ok(());
        }
        let Self { link, core, decoder, .. } = self;
        let mut late = 0u32;
        let mut heard = 0usize;
        core.read_until(&mut **link, until, |core, chunk, _| {
            heard += chunk.len();
            decoder.push(chunk);
            while let Some(item) = decoder.next() {
                match item {
                    Err(FrameError::Garbage { .. }) => continue,
                    Ok(ack) => core.trace(|| TraceEvent::Note(format!("dropped a late answer: {ack}"))),
                    Err(e) => core.trace(|| TraceEvent::Note(format!("dropped a late answer: bad frame: {e}"))),
                }
                late += 1;
                if late >= owed {
                    return ControlFlow::Break(());
                }
            }
            ControlFlow::Continue(())
        })
        .map_err(SessionError::from)?;
        if late < owed {
            self.silent = heard == 0;
            let lost = owed - late;
            self.core.trace(|| {
                TraceEvent::Note(format!("{lost} answer(s) owed to a timed-out request not seen: taken as lost"))
            });
        }
        self.owed = 0;
        self.owed_until = None;
        Ok(())
    }

    fn handle(&mut self, t: &mut Transaction, ack: Ack) -> Result<Step, PacError> {
        self.last_status = Some(ack.status);
        self.last_ack = Some(ack);
        self.last_quit = Some(ack.quit);
        self.last_check = Some(ack.check_rule);
        match t.handle_ack(ack) {
            Ok(step) => Ok(step),
            Err(TransactionError::Device(d)) => {
                Err(SessionError::refused(TARGET, t.command().to_string(), (&d).into()).into())
            }
            Err(TransactionError::AlreadyDone) => Err(SessionError::Malformed {
                target: TARGET.into(),
                source: DecodeError::Malformed("acknowledge after the command had finished".into()),
            }
            .into()),
        }
    }

    fn run(&mut self, cmd: &Command, observe: &mut dyn FnMut(&Progress) -> bool) -> Result<Done, PacError> {
        let start = self.core.clock.now();
        let mut t = self.begin(cmd)?;
        let mut ack = self.await_ack(&t)?;
        loop {
            let running = t.is_busy().then(|| t.clone());
            let step = match self.handle(&mut t, ack) {
                Ok(step) => step,
                Err(e) => {
                    // A poll refused: the command was running a poll ago
                    // and nothing says it ended, so it stays unfinished here
                    // (only polls or a stop follow; a follower stops it).
                    self.busy = running;
                    return Err(e);
                }
            };
            let elapsed = self.core.clock.now() - start;
            let last = match step {
                Step::Done(ack) => {
                    observe(&Progress { command: *cmd, ack, polls: t.polls(), elapsed });
                    return Ok(Done { ack, polls: t.polls(), elapsed });
                }
                Step::NeedPoll { last, .. } => last,
            };
            if !observe(&Progress { command: *cmd, ack: last, polls: t.polls(), elapsed }) {
                let polls = t.polls();
                self.busy = Some(t);
                return Err(PacError::Abandoned { code: cmd.code, polls, last });
            }
            if elapsed >= self.busy_timeout {
                self.busy = Some(t);
                let what = format!("running {cmd}, BE = 0");
                return Err(SessionError::wait_expired(TARGET, what, self.busy_timeout, None).into());
            }
            self.core.clock.sleep(self.poll_interval);
            ack = match self.send_poll(&mut t) {
                Ok(a) => a,
                Err(e) => {
                    // The command is still running: keep it so nothing but
                    // polls (or an explicit stop) follows.
                    self.busy = Some(t);
                    return Err(e);
                }
            };
        }
    }

    /// The first acknowledge within the answer timeout. Bytes outside frames
    /// are skipped (traced); a frame with a bad CHECK or bad fields is malformed.
    /// An acknowledge that cannot be `t`'s answer is skipped (traced) and the
    /// wait goes on; the line is then settled before the next request.
    fn await_ack(&mut self, t: &Transaction) -> Result<Ack, PacError> {
        let cmd = t.command();
        // A poll's answer is awaited patiently, too: given up, it would
        // hold the line that long all the same, and the running command
        // would have to be stopped for want of it.
        let patient = (self.patient || t.polls() > 0) && !self.silent;
        let timeout = self.answer_timeout(24) + if patient { MAX_LATE } else { Duration::ZERO };
        let char_time = Duration::from_micros(u64::from(self.bits_per_char) * 1_000_000 / u64::from(self.baud));
        let Self { link, core, decoder, line, owed, owed_until, silent, .. } = self;
        let deadline = core.now() + timeout;
        let ack = core.read_until(&mut **link, deadline, |core, chunk, until| {
            *silent &= chunk.is_empty();
            decoder.push(chunk);
            let started = !chunk.is_empty();
            while let Some(item) = decoder.next() {
                match item {
                    Ok(ack) if !t.could_answer(&ack) => {
                        core.trace(|| {
                            TraceEvent::Note(format!(
                                "skipped: {ack} cannot answer {cmd} (stale, of an older exchange)"
                            ))
                        });
                        *line = Line::Suspect;
                    }
                    Ok(ack) => {
                        core.trace(|| TraceEvent::Received(ack.to_string()));
                        return ControlFlow::Break(Ok(ack));
                    }
                    Err(e @ FrameError::Garbage { .. }) => core.trace(|| TraceEvent::Note(format!("skipped: {e}"))),
                    Err(e) => {
                        core.trace(|| TraceEvent::Received(format!("bad frame: {e}")));
                        let source = DecodeError::Malformed(e.to_string());
                        return ControlFlow::Break(Err(SessionError::Malformed { target: TARGET.into(), source }));
                    }
                }
            }
            // An acknowledge has begun and is shorter than the shortest one:
            // the rest cannot be on the line before its characters' wire
            // time. Reading at once would wake this thread once per
            // character (the dashboard's PA-CONTROL line is busy all the
            // time); waiting out all but the last of them ends the exchange
            // no later, and reads them in one piece.
            let held = decoder.buffered();
            if started && held > 0 && held + 1 < MIN_ACK_CHARS {
                let rest = char_time * (MIN_ACK_CHARS - held - 1) as u32;
                let left = until.saturating_duration_since(core.now());
                core.sleep(rest.min(left));
            }
            ControlFlow::Continue(())
        });
        match ack.map_err(SessionError::from)? {
            Some(ack) => Ok(ack?),
            None => {
                let n = decoder.buffered();
                if n > 0 {
                    core.trace(|| TraceEvent::Note(format!("{n} byte(s) of an incomplete frame at the timeout")));
                }
                if !*silent {
                    *owed += 1;
                    *owed_until = Some(core.now() + MAX_LATE);
                }
                Err(SessionError::Timeout { target: TARGET.into(), what: cmd.to_string(), timeout }.into())
            }
        }
    }
}

impl Drop for Pac {
    /// The next client on this line would take the owed answers for its own.
    fn drop(&mut self) {
        let _ = self.await_owed();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::clock::{Clock, VirtualClock};
    use crate::link::LinkError;
    use crate::proto::pac::Par2;
    use crate::session::RetryPolicy;
    use std::collections::VecDeque;
    use std::sync::{Arc, Mutex};
    use std::time::Instant;

    /// Bytes on the wire and the instant they arrive.
    type Arrival = (Instant, Vec<u8>);

    /// A scripted line: each write is recorded and answered with the next
    /// scripted reply (`None`: silence).
    #[derive(Clone, Default)]
    struct Script {
        written: Arc<Mutex<Vec<Vec<u8>>>>,
        replies: Arc<Mutex<VecDeque<Option<Vec<u8>>>>>,
        pending: Arc<Mutex<Vec<u8>>>,
        /// An answer on its way when the session starts: clearing the input
        /// does not reach it, it shows up at the next read.
        inflight: Arc<Mutex<Vec<u8>>>,
        /// Bytes still on the wire: each arrives at its instant, out of
        /// reach of clearing the input until then.
        arriving: Arc<Mutex<Vec<Arrival>>>,
        /// How long a reply takes to arrive (zero: at once).
        latency: Duration,
    }

    struct ScriptLink {
        s: Script,
        clock: VirtualClock,
    }

    impl ByteLink for ScriptLink {
        fn write_all(&mut self, bytes: &[u8]) -> Result<(), LinkError> {
            self.s.written.lock().unwrap().push(bytes.to_vec());
            if let Some(Some(r)) = self.s.replies.lock().unwrap().pop_front() {
                if self.s.latency.is_zero() {
                    self.s.pending.lock().unwrap().extend(r);
                } else {
                    self.s.arrive(self.clock.now() + self.s.latency, r);
                }
            }
            Ok(())
        }
        fn read(&mut self, buf: &mut [u8], timeout: Duration) -> Result<usize, LinkError> {
            let mut p = self.s.pending.lock().unwrap();
            let late: Vec<u8> = self.s.inflight.lock().unwrap().drain(..).collect();
            p.splice(0..0, late);
            let end = self.clock.now() + timeout;
            loop {
                let mut arriving = self.s.arriving.lock().unwrap();
                let now = self.clock.now();
                while arriving.first().is_some_and(|(at, _)| *at <= now) {
                    p.extend(arriving.remove(0).1);
                }
                match arriving.first() {
                    Some((at, _)) if p.is_empty() && *at <= end => self.clock.advance(*at - now),
                    _ => break,
                }
            }
            if p.is_empty() {
                self.clock.advance(end - self.clock.now());
                return Ok(0);
            }
            let n = p.len().min(buf.len());
            buf[..n].copy_from_slice(&p[..n]);
            p.drain(..n);
            Ok(n)
        }
        fn clear_input(&mut self) -> Result<(), LinkError> {
            self.s.pending.lock().unwrap().clear();
            Ok(())
        }
    }

    impl Script {
        fn arrive(&self, at: Instant, bytes: Vec<u8>) {
            let mut a = self.arriving.lock().unwrap();
            a.push((at, bytes));
            a.sort_by_key(|(at, _)| *at);
        }
    }

    fn hex(s: &str) -> Vec<u8> {
        s.split_whitespace().map(|b| u8::from_str_radix(b, 16).unwrap()).collect()
    }

    fn ack(quit: u16, be: bool, status: u16, q_par: Par2, rule: CheckRule) -> Vec<u8> {
        Ack { quit, be, status, error: 0, q_par, check_rule: rule }.encode().unwrap()
    }

    fn session(replies: Vec<Option<Vec<u8>>>) -> (Pac, Script, VirtualClock) {
        session_with_latency(replies, Duration::ZERO)
    }

    fn session_with_latency(replies: Vec<Option<Vec<u8>>>, latency: Duration) -> (Pac, Script, VirtualClock) {
        let clock = VirtualClock::new();
        let s = Script { replies: Arc::new(Mutex::new(replies.into())), latency, ..Default::default() };
        let link = ScriptLink { s: s.clone(), clock: clock.clone() };
        let pac = Pac::new(Box::new(link), 9600, SerialFormat::F7N1).with_clock(Arc::new(clock.clone()));
        (pac, s, clock)
    }

    fn written(s: &Script) -> Vec<Vec<u8>> {
        s.written.lock().unwrap().clone()
    }

    // Manual 3.4.3: start online, then 0A87 to 5552.0 with three polls whose
    // acknowledges carry the live position; the observer sees each of them.
    #[test]
    fn manual_3_4_3_through_the_session() {
        let replies = [
            "01 02 30 3B 31 3B 33 31 3B 30 3B 30 3B 30 03 38 04",
            "01 02 30 3B 30 3B 33 31 3B 30 3B 31 3B 31 32 35 35 2E 30 30 30 03 33 38 04",
            "01 02 30 3B 30 3B 33 31 3B 30 3B 31 3B 31 35 31 36 2E 39 35 30 03 34 32 04",
            "01 02 30 3B 30 3B 33 31 3B 30 3B 31 3B 32 36 33 34 2E 37 35 30 03 33 36 04",
            "01 02 30 3B 31 3B 33 31 3B 30 3B 31 3B 35 35 35 32 2E 30 30 30 03 33 35 04",
        ];
        let (mut pac, s, clock) = session(replies.iter().map(|r| Some(hex(r))).collect());
        let done = pac.transact(&Command::new(0x0603, 0, Par2::Int(0))).unwrap();
        assert_eq!(done.ack.status, 31);
        // "0;1;31;0;0;0" XORs to 8 without ETX.
        assert_eq!(pac.last_check_rule(), Some(CheckRule::Strict));
        let t0 = clock.now();
        let mut seen = Vec::new();
        let done = pac
            .transact_with(&Command::new(0x0A87, 2, Par2::Float(5552.0)), &mut |p| {
                seen.push((p.ack.q_par.as_f64(), p.ack.be, p.polls));
                true
            })
            .unwrap();
        assert_eq!(done.ack.q_par, Par2::Float(5552.0));
        assert_eq!(done.polls, 3);
        assert_eq!(
            seen,
            [(1255.0, false, 0), (1516.95, false, 1), (2634.75, false, 2), (5552.0, true, 3)],
            "every acknowledge reaches the observer"
        );
        assert!(clock.now() - t0 >= DEFAULT_POLL_INTERVAL * 3, "polls are spaced by the interval");
        let w = written(&s);
        assert_eq!(w[0], hex("01 02 30 36 30 33 3B 30 3B 30 3B 30 03 31 34 04"));
        assert_eq!(w[1], b"\x01\x020A87;2;1;5552.0\x0395\x04");
        assert_eq!(&w[2..], [vec![0x04], vec![0x04], vec![0x04]]);
        assert!(pac.busy_command().is_none());
    }

    #[test]
    fn quit_becomes_a_device_error_with_hex_decimal_and_text() {
        let (mut pac, _, _) = session(vec![Some(ack(0x41, true, 31, Par2::Float(0.0), CheckRule::Strict))]);
        let err = pac.transact(&Command::new(0x0A94, 2, Par2::Float(99999.0))).unwrap_err();
        let PacError::Session(e @ SessionError::Device { .. }) = &err else { panic!("{err:?}") };
        assert_eq!(e.kind(), crate::session::ErrorKind::Device);
        let text = e.to_string();
        assert!(text.contains("0x41 (65): position outside range"), "{text}");
        assert!(text.contains("0A94"), "{text}");
    }

    #[test]
    fn only_polls_while_busy_and_abandon_and_stop() {
        let replies = vec![
            Some(ack(0, false, 31, Par2::Float(0.0), CheckRule::WithEtx)),
            Some(ack(0, false, 31, Par2::Float(10.0), CheckRule::WithEtx)),
            // 0A93: BE = 0, then standstill.
            Some(ack(0, false, 31, Par2::Float(12.0), CheckRule::WithEtx)),
            Some(ack(0, true, 31, Par2::Float(13.5), CheckRule::WithEtx)),
        ];
        let (mut pac, s, _) = session(replies);
        let mv = Command::new(0x0A87, 1, Par2::Float(100.0));
        let mut n = 0;
        let err = pac
            .transact_with(&mv, &mut |_| {
                n += 1;
                n < 2
            })
            .unwrap_err();
        assert!(matches!(err, PacError::Abandoned { code: 0x0A87, polls: 1, .. }), "{err:?}");
        assert_eq!(pac.busy_command(), Some(&mv));
        let before = written(&s).len();
        // Anything but a poll is refused locally, nothing is written.
        let read = Command::new(0x190C, 1, Par2::Float(0.0));
        let err = pac.transact(&read).unwrap_err();
        assert!(matches!(err, PacError::Busy { busy: 0x0A87, refused: 0x190C }), "{err:?}");
        assert_eq!(err.kind(), crate::session::ErrorKind::Usage);
        assert_eq!(written(&s).len(), before);
        let stop = Command::new(0x0A93, 1, Par2::Float(0.0));
        let done = pac.abandon_and_stop(&stop).unwrap();
        assert_eq!(done.ack.q_par, Par2::Float(13.5));
        assert!(pac.busy_command().is_none());
        let w = written(&s);
        assert_eq!(w[before], stop.encode().unwrap());
        assert_eq!(w[before + 1], [0x04]);
    }

    #[test]
    fn start_then_poll() {
        let replies = vec![
            Some(ack(0, false, 31, Par2::Int(0), CheckRule::Strict)),
            Some(ack(0, true, 31, Par2::Int(0), CheckRule::Strict)),
        ];
        let (mut pac, _, _) = session(replies);
        let r = Command::new(0x0A84, 2, Par2::Int(0));
        assert!(matches!(pac.start(&r).unwrap(), Step::NeedPoll { .. }));
        assert!(matches!(pac.transact(&Command::new(0x190B, 0, Par2::Int(0))), Err(PacError::Busy { .. })));
        assert!(matches!(pac.poll().unwrap(), Step::Done(_)));
        assert!(pac.busy_command().is_none());
        assert!(pac.poll().is_err(), "nothing left to poll");
    }

    fn read_1910(pac: &mut Pac) -> Par2 {
        pac.transact(&Command::new(0x1910, 1, Par2::Int(0))).unwrap().ack.q_par
    }

    // A client killed mid-exchange at 9600 baud: the answer to its 190C
    // (a position, float) reaches the line after this 1910 was sent.
    #[test]
    fn an_acknowledge_that_cannot_answer_the_request_is_skipped() {
        let stale = ack(0, true, 31, Par2::Float(161.477), CheckRule::Strict);
        let mine = ack(0, true, 31, Par2::Int(7), CheckRule::Strict);
        let (mut pac, s, _) =
            session(vec![Some([stale, mine].concat()), Some(ack(0, true, 31, Par2::Int(8), CheckRule::Strict))]);
        assert_eq!(read_1910(&mut pac), Par2::Int(7));
        assert_eq!(read_1910(&mut pac), Par2::Int(8), "no offset left for the next exchange");
        assert_eq!(written(&s).len(), 2);
    }

    // The same, with an answer of the same type on its way when the session
    // starts: it is pending at the first look, and only dropping it tells it
    // from the real answer.
    #[test]
    fn an_answer_on_its_way_at_the_start_is_drained() {
        let replies = (7..9).map(|v| Some(ack(0, true, 31, Par2::Int(v), CheckRule::Strict))).collect();
        let (mut pac, s, _) = session(replies);
        *s.inflight.lock().unwrap() = ack(0, true, 31, Par2::Int(99), CheckRule::Strict);
        assert_eq!(read_1910(&mut pac), Par2::Int(7));
        assert_eq!(read_1910(&mut pac), Par2::Int(8));
    }

    // Input pending at the start means a killed client's answers are still
    // coming: the next one, 2 ms later, is dropped too, because the session
    // waits for a quiet line before it sends.
    #[test]
    fn pending_input_at_the_start_is_waited_out_to_a_quiet_line() {
        let replies = vec![Some(ack(0, true, 31, Par2::Int(7), CheckRule::Strict))];
        let (mut pac, s, clock) = session_with_latency(replies, Duration::from_millis(5));
        *s.inflight.lock().unwrap() = ack(0, true, 31, Par2::Int(99), CheckRule::Strict);
        s.arrive(clock.now() + Duration::from_millis(2), ack(0, true, 31, Par2::Int(98), CheckRule::Strict));
        assert_eq!(read_1910(&mut pac), Par2::Int(7));
    }

    // A one-shot command on a clean line: nothing pending, so no wait for a
    // quiet line before the request (it used to cost an answer timeout).
    #[test]
    fn a_clean_line_costs_no_wait_at_the_start() {
        let (mut pac, s, clock) = session(vec![Some(ack(0, true, 31, Par2::Int(7), CheckRule::Strict))]);
        let t0 = clock.now();
        assert_eq!(read_1910(&mut pac), Par2::Int(7));
        assert_eq!(clock.now() - t0, Duration::ZERO);
        assert_eq!(written(&s).len(), 1);
    }

    // After a skipped stale acknowledge more of them may still be coming (a
    // killed client's later answers): the next request waits for a quiet
    // line, even with nothing pending yet, so the one arriving 3 ms later is
    // not taken for the answer to it.
    #[test]
    fn after_a_skipped_stale_acknowledge_the_next_request_waits_for_quiet() {
        let stale = ack(0, true, 31, Par2::Float(161.477), CheckRule::Strict);
        let mine = ack(0, true, 31, Par2::Int(7), CheckRule::Strict);
        let replies = vec![Some([stale, mine].concat()), Some(ack(0, true, 31, Par2::Int(8), CheckRule::Strict))];
        let (mut pac, s, clock) = session_with_latency(replies, Duration::from_millis(5));
        assert_eq!(read_1910(&mut pac), Par2::Int(7));
        s.arrive(clock.now() + Duration::from_millis(3), ack(0, true, 31, Par2::Int(99), CheckRule::Strict));
        assert_eq!(read_1910(&mut pac), Par2::Int(8));
    }

    // Issue 22: a 1910 read answered 150 ms late, after its 97 ms timeout.
    // The retry must not take that late answer (the same type as its own)
    // for its own: it waits for it, drops it, then sends.
    #[test]
    fn a_late_answer_is_dropped_before_the_retry_not_taken_by_it() {
        let replies = vec![None, Some(ack(0, true, 31, Par2::Int(7), CheckRule::Strict))];
        let (mut pac, s, clock) = session(replies);
        let t0 = clock.now();
        s.arrive(t0 + Duration::from_millis(150), ack(0, true, 31, Par2::Int(99), CheckRule::Strict));
        assert_eq!(read_1910(&mut pac), Par2::Int(7));
        assert_eq!(written(&s).len(), 2);
        assert!(clock.now() - t0 >= Duration::from_millis(150), "the retry went out after the late answer");
        assert_eq!(read_1910_of(&mut pac, Some(8), &s), Par2::Int(8), "and nothing is left over for the next one");
    }

    fn read_1910_of(pac: &mut Pac, value: Option<i64>, s: &Script) -> Par2 {
        s.replies.lock().unwrap().push_back(value.map(|v| ack(0, true, 31, Par2::Int(v), CheckRule::Strict)));
        read_1910(pac)
    }

    // The first answer of a running 0A87 comes late, after its timeout: the
    // stop that follows waits for it and takes its own answer, not that one.
    #[test]
    fn a_late_answer_is_not_taken_for_the_stops() {
        let replies = vec![None, Some(ack(0, true, 31, Par2::Float(13.5), CheckRule::Strict))];
        // Answers take 80 ms: the late one would come first.
        let (mut pac, s, clock) = session_with_latency(replies, Duration::from_millis(80));
        let mv = Command::new(0x0A87, 1, Par2::Float(100.0));
        s.arrive(clock.now() + Duration::from_millis(150), ack(0, false, 31, Par2::Float(0.0), CheckRule::Strict));
        let err = pac.transact(&mv).unwrap_err();
        assert!(matches!(err, PacError::Session(SessionError::Timeout { .. })), "{err:?}");
        let done = pac.abandon_and_stop(&Command::new(0x0A93, 1, Par2::Float(0.0))).unwrap();
        assert_eq!(done.ack.q_par, Par2::Float(13.5), "the stop's own answer");
        assert_eq!(written(&s).len(), 2);
    }

    // A poll's answer is awaited up to MAX_LATE beyond the timeout: taken
    // late rather than given up, which would leave a move to be stopped.
    #[test]
    fn a_late_poll_answer_is_the_polls_own() {
        let replies = vec![Some(ack(0, false, 31, Par2::Float(0.0), CheckRule::Strict)), None];
        let (mut pac, s, clock) = session(replies);
        let mv = Command::new(0x0A87, 1, Par2::Float(100.0));
        let at = clock.now() + DEFAULT_POLL_INTERVAL + pac.answer_timeout(24) + Duration::from_millis(500);
        s.arrive(at, ack(0, true, 31, Par2::Float(100.0), CheckRule::Strict));
        let done = pac.transact(&mv).unwrap();
        assert_eq!((done.ack.q_par, done.polls), (Par2::Float(100.0), 1));
        assert_eq!(written(&s).len(), 2);
        assert!(pac.busy_command().is_none());
    }

    // An owed answer that never comes (lost) holds the next request back
    // for at most MAX_LATE.
    #[test]
    fn a_lost_answer_holds_the_next_request_back_for_at_most_max_late() {
        let (mut pac, s, clock) = session(vec![None, Some(ack(0, true, 31, Par2::Int(7), CheckRule::Strict))]);
        pac.set_retry(RetryPolicy { read_retries: 1 });
        let t0 = clock.now();
        assert_eq!(read_1910(&mut pac), Par2::Int(7));
        let timeout = pac.answer_timeout(24);
        assert_eq!(clock.now() - t0, timeout + MAX_LATE);
        assert_eq!(written(&s).len(), 2);
    }

    // A controller that does not answer at all is silent, not late: after
    // the first owed answer is given up, later timeouts are not waited out
    // (nor a stop's answers awaited longer) until a byte comes.
    #[test]
    fn a_silent_line_is_not_waited_out_twice() {
        let (mut pac, s, clock) = session(vec![None, None, None, None]);
        pac.set_retry(RetryPolicy { read_retries: 1 });
        let timeout = pac.answer_timeout(24);
        let t0 = clock.now();
        assert!(pac.transact(&Command::new(0x1910, 1, Par2::Int(0))).is_err());
        assert_eq!(written(&s).len(), 2, "sent twice");
        assert_eq!(clock.now() - t0, timeout * 2 + MAX_LATE, "one wait for the first owed answer");
        let t1 = clock.now();
        let stop = Command::new(0x0A93, 1, Par2::Float(0.0));
        assert!(pac.patiently(|p| p.transact(&stop)).is_err());
        assert!(pac.transact(&stop).is_err());
        assert_eq!(clock.now() - t1, timeout * 2, "no more waits for what does not come");
        assert_eq!(written(&s).len(), 4);
        // A byte heard ends it: the next timeout is waited out again.
        s.replies.lock().unwrap().push_back(Some(b"x".to_vec()));
        s.replies.lock().unwrap().push_back(Some(ack(0, true, 31, Par2::Int(7), CheckRule::Strict)));
        let t2 = clock.now();
        assert_eq!(read_1910(&mut pac), Par2::Int(7));
        assert_eq!(clock.now() - t2, timeout + MAX_LATE, "the retry waited for the owed answer");
    }

    // A session ended with an answer owed waits for it, so the next client
    // on the line does not take it for its own.
    #[test]
    fn a_session_dropped_with_an_answer_owed_waits_for_it() {
        let (mut pac, s, clock) = session(vec![None]);
        pac.set_retry(RetryPolicy { read_retries: 0 });
        s.arrive(clock.now() + Duration::from_millis(150), ack(0, true, 31, Par2::Int(99), CheckRule::Strict));
        assert!(pac.transact(&Command::new(0x1910, 1, Par2::Int(0))).is_err());
        drop(pac);
        assert!(s.arriving.lock().unwrap().is_empty(), "read off the line");
        assert!(s.pending.lock().unwrap().is_empty());
    }

    // A poll refused while a command runs: nothing says it ended, so it
    // stays the unfinished command (only polls or a stop may follow).
    #[test]
    fn a_refused_poll_leaves_the_command_unfinished() {
        let replies = vec![
            Some(ack(0, false, 31, Par2::Float(0.0), CheckRule::Strict)),
            Some(ack(0x14, true, 31, Par2::Float(0.0), CheckRule::Strict)),
        ];
        let (mut pac, _, _) = session(replies);
        let mv = Command::new(0x0A87, 1, Par2::Float(100.0));
        let err = pac.transact(&mv).unwrap_err();
        assert_eq!(err.kind(), crate::session::ErrorKind::Device, "{err:?}");
        assert_eq!(pac.busy_command(), Some(&mv));
        // Refused at once, it never ran.
        let (mut pac, _, _) = session(vec![Some(ack(0x14, true, 31, Par2::Float(0.0), CheckRule::Strict))]);
        assert!(pac.transact(&mv).is_err());
        assert_eq!(pac.busy_command(), None);
    }

    // The stop of last resort takes an answer up to MAX_LATE beyond the
    // timeout (it would hold the line that long anyway); a late poll
    // answer, too. Outside `patiently` the same answer is a timeout.
    #[test]
    fn patiently_takes_answers_up_to_max_late_beyond_the_timeout() {
        let replies = vec![
            Some(ack(0, false, 31, Par2::Float(12.0), CheckRule::Strict)),
            Some(ack(0, true, 31, Par2::Float(13.5), CheckRule::Strict)),
        ];
        let late = Duration::from_millis(400);
        let (mut pac, s, _) = session_with_latency(replies.clone(), late);
        let stop = Command::new(0x0A93, 1, Par2::Float(0.0));
        let done = pac.patiently(|p| p.transact(&stop)).unwrap();
        assert_eq!((done.ack.q_par, done.polls), (Par2::Float(13.5), 1));
        assert_eq!(written(&s).len(), 2);
        let (mut pac, _, _) = session_with_latency(replies, late);
        let err = pac.transact(&stop).unwrap_err();
        assert_eq!(err.kind(), crate::session::ErrorKind::Timeout, "{err:?}");
        assert!(!pac.patient, "patience ends with the call");
    }

    // A single poll that goes unanswered leaves the command unfinished.
    #[test]
    fn an_unanswered_poll_leaves_the_command_unfinished() {
        let (mut pac, _, _) = session(vec![Some(ack(0, false, 31, Par2::Int(0), CheckRule::Strict)), None]);
        let r = Command::new(0x0A84, 2, Par2::Int(0));
        assert!(matches!(pac.start(&r).unwrap(), Step::NeedPoll { .. }));
        assert!(pac.poll().is_err());
        assert_eq!(pac.busy_command(), Some(&r));
    }

    #[test]
    fn reads_are_retried_motion_is_not() {
        let ok = ack(0, true, 31, Par2::Float(5.0), CheckRule::Strict);
        let (mut pac, s, _) = session(vec![None, Some(ok.clone())]);
        let done = pac.transact(&Command::new(0x190C, 1, Par2::Float(0.0))).unwrap();
        assert_eq!(done.ack.q_par, Par2::Float(5.0));
        assert_eq!(written(&s).len(), 2);

        let (mut pac, s, _) = session(vec![None, Some(ok)]);
        let err = pac.transact(&Command::new(0x0A94, 1, Par2::Float(5.0))).unwrap_err();
        assert!(matches!(err, PacError::Session(SessionError::Timeout { .. })), "{err:?}");
        assert_eq!(written(&s).len(), 1, "a move is sent once");
    }

    #[test]
    fn bad_check_is_malformed_and_garbage_is_skipped() {
        let mut bad = ack(0, true, 31, Par2::Int(7), CheckRule::Strict);
        let n = bad.len();
        bad[n - 2] = b'9';
        bad[n - 3] = b'9';
        let (mut pac, _, _) = session(vec![Some(bad)]);
        pac.set_retry(RetryPolicy { read_retries: 0 });
        let err = pac.transact(&Command::new(0x1906, 1, Par2::Int(0))).unwrap_err();
        assert_eq!(err.kind(), crate::session::ErrorKind::Malformed, "{err:?}");

        let mut noisy = b"\xff\x00junk".to_vec();
        noisy.extend(ack(0, true, 31, Par2::Int(7), CheckRule::Strict));
        let (mut pac, _, _) = session(vec![Some(noisy)]);
        assert_eq!(pac.transact(&Command::new(0x1906, 1, Par2::Int(0))).unwrap().ack.q_par, Par2::Int(7));
        assert_eq!(pac.last_check_rule(), Some(CheckRule::Strict));
    }

    #[test]
    fn check_rule_option_and_busy_timeout() {
        let replies = (0..100).map(|_| Some(ack(0, false, 31, Par2::Int(0), CheckRule::Strict))).collect();
        let (mut pac, s, _) = session(replies);
        pac.set_check_rule(CheckRule::WithEtx);
        pac.set_busy_timeout(Duration::from_millis(500));
        let err = pac.transact(&Command::new(0x0A84, 3, Par2::Int(0))).unwrap_err();
        assert_eq!(err.kind(), crate::session::ErrorKind::WaitTimeout, "{err:?}");
        assert!(err.to_string().starts_with("wait timed out after 0.5 s: PA-CONTROL was still running 0A84"), "{err}");
        assert_eq!(written(&s)[0], b"\x01\x020A84;3;0;0\x03118\x04");
        assert!(pac.busy_command().is_some(), "the reference drive is still running");
    }

    #[test]
    fn default_timeout_adds_wire_time() {
        let (pac, _, _) = session(vec![]);
        // 24 + 48 characters at 9 bits and 9600 baud: 67.5 ms.
        assert_eq!(pac.answer_timeout(24), Duration::from_micros(30_000 + 67_500));
    }

    proptest::proptest! {
        // Whatever the line delivers, the session answers with a value or a
        // typed error, never a panic; bytes without a frame are a timeout.
        #[test]
        fn random_answers_never_panic(reply in proptest::collection::vec(proptest::prelude::any::<u8>(), 0..200)) {
            let (mut pac, _, _) = session(vec![Some(reply.clone()), Some(reply.clone()), Some(reply)]);
            pac.set_busy_timeout(Duration::from_millis(200));
            let _ = pac.transact(&Command::new(0x190C, 1, Par2::Float(0.0)));
            let _ = pac.transact(&Command::new(0x0A94, 1, Par2::Float(1.0)));
        }
    }
}
