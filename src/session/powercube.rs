//! The PowerCube session: one request, one matching acknowledge, over CAN or
//! RS232.
//!
//! On CAN, requests can be pipelined ([`PowerCube::transact_many`]): every
//! request is sent first, then the answers are collected within one timeout,
//! which is what makes a 31-id scan take one timeout instead of 31.
//!
//! A burst can also be sent ([`PowerCube::send_burst`]) and collected later
//! ([`PowerCube::collect`]), with more requests sent in between: the bus then
//! carries the next burst while the answers of the first one cross the link.
//! Every burst still waiting for answers is remembered, oldest first, and
//! each received frame settles the first request of the oldest burst that it
//! answers: a module answers in the order it was asked, so two reads of the
//! same parameter in two bursts get their answers in order. A burst nobody
//! will collect is [abandoned](PowerCube::abandon): it keeps taking its own
//! answers until its deadline, so that none of them is taken for the answer
//! to a later request.

use std::collections::VecDeque;
use std::ops::ControlFlow;
use std::sync::Arc;
use std::time::{Duration, Instant};

use super::core::{core_setters, with_read_retries, Core};
use super::{SessionError, TraceEvent};
use crate::link::{ByteLink, CanLink};
use crate::proto::powercube::can::Broadcast;
use crate::proto::powercube::rs232::{self, Direction};
use crate::proto::powercube::session::{self as matcher, CanExchange, Rs232Verdict};
use crate::proto::powercube::table::ParamDef;
use crate::proto::powercube::{frame::Value, ModuleId, Request, Response};
use crate::proto::{CanFrame, DecodeError};

mod refresh;

pub use refresh::RefreshStats;
use refresh::{Refresh, Refreshing};

/// Default CAN answer timeout (the vendor library's).
pub const CAN_TIMEOUT: Duration = Duration::from_millis(100);
/// Default RS232 timeout before wire time is added (the vendor library's).
pub const RS232_BASE_TIMEOUT: Duration = Duration::from_millis(30);
/// Longest RS232 frame on the wire: STX, ETX and 11 bytes that may all need DLE.
const RS232_MAX_FRAME: u32 = 24;

enum Transport {
    Can(Box<dyn CanLink>),
    Rs232 { link: Box<dyn ByteLink>, decoder: rs232::Decoder, baud: u32 },
}

pub struct PowerCube {
    transport: Transport,
    core: Core,
    /// RS232: give up when no answer byte has come this long after the
    /// request has left (absent modules never answer; present ones answer at once).
    answer_start: Option<Duration>,
    /// Request frames of the CAN burst being sent, kept to spare an allocation per exchange.
    frames: Vec<CanFrame>,
    /// CAN bursts sent whose answers are still awaited, oldest first.
    in_flight: VecDeque<InFlight>,
    /// The id the next burst gets.
    next_burst: u64,
    /// The watchdog refresh while a supervised motion lasts (CAN only).
    refresh: Option<Refresh>,
}

/// A CAN burst sent and not collected yet.
struct InFlight {
    id: u64,
    exchange: CanExchange,
    /// It takes answers until then; after it, those missing are timeouts.
    deadline: Instant,
    /// When its first answer came: its modules read their values about then.
    first_answer: Option<Instant>,
    /// Nobody will collect it: it only keeps its late answers from being
    /// taken for the answers of later requests.
    abandoned: bool,
}

/// What a received frame was to the bursts in flight.
enum Routed {
    /// It settled a request of the burst with this id.
    Settled(u64),
    /// It answered a request of an abandoned burst.
    Abandoned,
    /// It answered nothing still awaited.
    Unmatched,
}

/// Hands `frame` to the oldest burst still taking answers that has a
/// request it answers.
fn route(in_flight: &mut VecDeque<InFlight>, frame: &CanFrame, now: Instant) -> Routed {
    for b in in_flight.iter_mut().filter(|b| now < b.deadline) {
        if b.exchange.handle(frame).is_some() {
            b.first_answer.get_or_insert(now);
            return if b.abandoned { Routed::Abandoned } else { Routed::Settled(b.id) };
        }
    }
    Routed::Unmatched
}

/// A burst sent with [`PowerCube::send_burst`]: hand it to
/// [`PowerCube::collect`] for its answers, or to [`PowerCube::abandon`].
#[derive(Debug)]
#[must_use = "a burst is collected or abandoned"]
pub struct Burst {
    id: u64,
    sent: Instant,
    /// RS232: the answers, taken one request after the other at the send.
    done: Option<Vec<Result<Response, SessionError>>>,
}

impl Burst {
    /// When its requests were handed to the link.
    pub fn sent(&self) -> Instant {
        self.sent
    }
}

/// The answers of a collected burst, in request order.
#[derive(Debug)]
pub struct Collected {
    pub answers: Vec<Result<Response, SessionError>>,
    /// When the first answer came (on RS232: when the requests went out).
    /// The modules read their values as the requests reach them, which with
    /// another burst queued ahead on the bus is later than [`Burst::sent`].
    pub first_answer: Option<Instant>,
}

core_setters!(PowerCube, timeout);

impl PowerCube {
    fn with_transport(transport: Transport, timeout: Duration) -> Self {
        Self {
            transport,
            core: Core::new(timeout),
            answer_start: None,
            frames: Vec::new(),
            in_flight: VecDeque::new(),
            next_burst: 0,
            refresh: None,
        }
    }

    pub fn over_can(link: Box<dyn CanLink>) -> Self {
        Self::with_transport(Transport::Can(link), CAN_TIMEOUT)
    }

    /// `baud` sets the default timeout: 30 ms plus the wire time of the
    /// longest request and answer.
    pub fn over_rs232(link: Box<dyn ByteLink>, baud: u32) -> Self {
        let timeout = RS232_BASE_TIMEOUT + rs232_wire_time(baud, 2 * RS232_MAX_FRAME);
        Self::with_transport(Transport::Rs232 { link, decoder: rs232::Decoder::new(), baud }, timeout)
    }

    /// RS232 only: time out early when the answer has not started this long
    /// after the request's last byte left (scans use it: an absent id costs
    /// the request's wire time plus this, not the whole timeout).
    pub fn set_answer_start_timeout(&mut self, t: Option<Duration>) {
        self.answer_start = t;
        // Said in the trace: the scan's figures (scripts/bench.py) are computed with it.
        if let Some(t) = t {
            let (ms, timeout) = (t.as_secs_f64() * 1e3, self.core.timeout.as_secs_f64() * 1e3);
            self.core
                .trace(|| TraceEvent::Note(format!("answer-start window {ms:.3} ms (answer timeout {timeout:.3} ms)")));
        }
    }

    pub fn is_can(&self) -> bool {
        matches!(self.transport, Transport::Can(_))
    }

    /// The per-id timeout a scan uses on RS232: the answer is due right after the request.
    pub fn rs232_baud(&self) -> Option<u32> {
        match &self.transport {
            Transport::Rs232 { baud, .. } => Some(*baud),
            Transport::Can(_) => None,
        }
    }

    /// Sends `req` to `module` and waits for its acknowledge. Reads are
    /// retried per the [`RetryPolicy`](super::RetryPolicy); nothing else is.
    pub fn transact(&mut self, module: ModuleId, req: &Request) -> Result<Response, SessionError> {
        with_read_retries(self, req.is_read(), None, |s| s.transact_once(module, req))
    }

    /// The retries of a read whose first attempt went out pipelined
    /// ([`Self::transact_many`]) and failed with `first`: the read is sent
    /// `read_retries` more times, so it goes out 1 + retries times in all, as
    /// with [`Self::transact`]. Anything but a read is not sent again.
    pub fn retry_read(
        &mut self,
        module: ModuleId,
        req: &Request,
        first: SessionError,
    ) -> Result<Response, SessionError> {
        with_read_retries(self, req.is_read(), Some(first), |s| s.transact_once(module, req))
    }

    fn transact_once(&mut self, module: ModuleId, req: &Request) -> Result<Response, SessionError> {
        match self.transport {
            Transport::Can(_) => {
                let reqs = [(module, *req)];
                let [answer] = <[_; 1]>::try_from(self.transact_many(&reqs)?).expect("one request, one answer");
                answer
            }
            Transport::Rs232 { .. } => self.rs232_transact(module, req),
        }
    }

    fn timeout_error(&self, module: ModuleId, req: &Request) -> SessionError {
        SessionError::Timeout { target: target(module), what: req.to_string(), timeout: self.core.timeout }
    }

    /// Sends every request, then collects the answers within one timeout
    /// after the last send (CAN). On RS232 the line is half-duplex, so the
    /// requests go one after the other, each with its own timeout. Answers
    /// are returned in request order. No retries here.
    pub fn transact_many(
        &mut self,
        reqs: &[(ModuleId, Request)],
    ) -> Result<Vec<Result<Response, SessionError>>, SessionError> {
        let burst = self.send_burst(reqs)?;
        Ok(self.collect(burst)?.answers)
    }

    /// The send half of [`Self::transact_many`]: on CAN every request goes
    /// out in one go and the answers are left for [`Self::collect`]; other
    /// requests (other bursts, a motion, a halt) may go out meanwhile. On
    /// RS232 (half-duplex) the requests are answered one after the other
    /// here, and the collect only hands the answers over.
    pub fn send_burst(&mut self, reqs: &[(ModuleId, Request)]) -> Result<Burst, SessionError> {
        let id = self.next_burst;
        self.next_burst += 1;
        let Transport::Can(link) = &mut self.transport else {
            let sent = self.core.now();
            let mut done = Vec::with_capacity(reqs.len());
            for (m, r) in reqs {
                match self.rs232_transact(*m, r) {
                    Err(e @ SessionError::Link(_)) => return Err(e),
                    other => done.push(other),
                }
            }
            return Ok(Burst { id, sent, done: Some(done) });
        };
        let core = &mut self.core;
        let in_flight = &mut self.in_flight;
        let mut link = Refreshing::new(&mut **link, self.refresh.as_mut());
        let now = core.now();
        in_flight.retain(|b| !(b.abandoned && (b.exchange.pending() == 0 || now >= b.deadline)));
        // Frames queued before the request cannot answer it, but may answer
        // a burst still in flight.
        core.drain(&mut link, |core, frame| {
            let note = match route(in_flight, &frame, core.now()) {
                Routed::Settled(_) => "ack (to a burst in flight)",
                Routed::Abandoned => "ignored (answers an abandoned burst)",
                Routed::Unmatched => "ignored (queued before the request)",
            };
            core.trace(|| TraceEvent::Received(format!("{frame:<22} {note}")));
        })?;
        let exchange = CanExchange::new(reqs);
        let mut frames = std::mem::take(&mut self.frames);
        frames.clear();
        frames.extend(exchange.frames());
        for (frame, (m, r)) in frames.iter().zip(reqs) {
            core.trace(|| TraceEvent::Sent(format!("{frame:<22} {r} to module {m}")));
        }
        let sent = core.now();
        let deadline = core.send_burst(&mut link, &frames);
        self.frames = frames;
        self.in_flight.push_back(InFlight { id, exchange, deadline: deadline?, first_answer: None, abandoned: false });
        Ok(Burst { id, sent, done: None })
    }

    /// The answers of `burst`, in request order, waiting for those still
    /// due up to its deadline (one timeout after its send); a timeout for
    /// each request not answered by then. Frames answering other bursts in
    /// flight are kept for them.
    pub fn collect(&mut self, burst: Burst) -> Result<Collected, SessionError> {
        if let Some(answers) = burst.done {
            return Ok(Collected { answers, first_answer: Some(burst.sent) });
        }
        let at = self.index_of(burst.id);
        let (deadline, pending) = (self.in_flight[at].deadline, self.in_flight[at].exchange.pending());
        let Transport::Can(link) = &mut self.transport else { unreachable!("only a CAN burst is collected later") };
        let mut link = Refreshing::new(&mut **link, self.refresh.as_mut());
        let in_flight = &mut self.in_flight;
        let received = self.core.collect(&mut link, deadline, pending, |core, frame| {
            let routed = route(in_flight, &frame, core.now());
            let note = match routed {
                Routed::Settled(id) if id == burst.id => "ack",
                Routed::Settled(_) => "ack (to another burst in flight)",
                Routed::Abandoned => "ignored (answers an abandoned burst)",
                Routed::Unmatched => "ignored (not ours)",
            };
            core.trace(|| TraceEvent::Received(format!("{frame:<22} {note}")));
            matches!(routed, Routed::Settled(id) if id == burst.id)
        });
        let done = self.in_flight.remove(self.index_of(burst.id)).expect("found above");
        received?;
        let reqs = done.exchange.requests().to_vec();
        let answers = done
            .exchange
            .into_answers()
            .into_iter()
            .zip(&reqs)
            .map(|(a, (m, r))| match a {
                Some(Ok(resp)) => Ok(resp),
                Some(Err(source)) => Err(SessionError::Malformed { target: target(*m), source }),
                None => Err(self.timeout_error(*m, r)),
            })
            .collect();
        Ok(Collected { answers, first_answer: done.first_answer })
    }

    /// Gives up `burst` without waiting: the answers still due are taken
    /// (and dropped) as they come, up to its deadline, and never handed to
    /// a later request. Nothing is waited for, so a halt can go out at once.
    pub fn abandon(&mut self, burst: Burst) {
        if burst.done.is_some() {
            return;
        }
        let at = self.index_of(burst.id);
        let b = &mut self.in_flight[at];
        b.abandoned = true;
        let due = b.exchange.pending();
        if due > 0 {
            self.core.trace(|| TraceEvent::Note(format!("burst abandoned with {due} answers still due")));
        }
    }

    /// CAN bursts sent and not yet collected (abandoned ones that may still
    /// take an answer included).
    pub fn bursts_in_flight(&self) -> usize {
        self.in_flight.len()
    }

    fn index_of(&self, id: u64) -> usize {
        self.in_flight
            .iter()
            .position(|b| b.id == id)
            .expect("a burst is collected or abandoned once, on the session that sent it")
    }

    fn rs232_transact(&mut self, module: ModuleId, req: &Request) -> Result<Response, SessionError> {
        let mut bytes = Vec::with_capacity(RS232_MAX_FRAME as usize);
        matcher::rs232_request(module, req, &mut bytes);
        self.core.trace(|| TraceEvent::Sent(format!("{} {req} to module {module}", hex(&bytes))));
        let timeout = self.core.timeout;
        let Transport::Rs232 { link, decoder, baud } = &mut self.transport else { unreachable!() };
        // Half-duplex: whatever is still in the buffers belongs to an older exchange.
        link.clear_input()?;
        *decoder = rs232::Decoder::new();
        link.write_all(&bytes)?;
        let sent = self.core.now();
        let full = sent + timeout;
        let start_deadline = self.answer_start.map(|t| sent + rs232_wire_time(*baud, bytes.len() as u32) + t);
        let mut started = false;
        let answer = self.core.read_until(
            &mut **link,
            start_deadline.map_or(full, |sd| full.min(sd)),
            |core, chunk, deadline| {
                if !chunk.is_empty() && !started {
                    started = true;
                    *deadline = full;
                }
                decoder.push(chunk);
                while let Some(item) = decoder.next_frame() {
                    let note = match (matcher::rs232_verdict(module, req, item.as_ref()), &item) {
                        (Rs232Verdict::Answer { response, declared_len, framed_len }, Ok(frame)) => {
                            core.trace(|| {
                                let mismatch = if declared_len != framed_len {
                                    format!(" (TELID says {declared_len} bytes, {framed_len} framed)")
                                } else {
                                    String::new()
                                };
                                TraceEvent::Received(format!("{:?}{mismatch} ack", frame.payload))
                            });
                            return ControlFlow::Break(Ok(response));
                        }
                        (Rs232Verdict::Malformed(source), _) => {
                            return ControlFlow::Break(Err(SessionError::Malformed { target: target(module), source }))
                        }
                        (Rs232Verdict::OtherCommand, Ok(f)) => {
                            format!("{:?} ignored (answers another command)", f.payload)
                        }
                        (Rs232Verdict::Foreign, Ok(f)) => {
                            format!("{:?} ignored (module {} {:?})", f.payload, f.module, f.dir)
                        }
                        (_, Err(e)) => format!("dropped: {e}"),
                        (_, Ok(f)) => format!("{:?} ignored", f.payload),
                    };
                    core.trace(|| TraceEvent::Received(note));
                }
                ControlFlow::Continue(())
            },
        )?;
        answer.unwrap_or_else(|| Err(self.timeout_error(module, req)))
    }

    /// Sends a broadcast; broadcasts are never acknowledged, so nothing is awaited.
    pub fn broadcast(&mut self, b: Broadcast) -> Result<(), SessionError> {
        match &mut self.transport {
            Transport::Can(link) => {
                let frame = b.frame();
                Refreshing::new(&mut **link, self.refresh.as_mut()).send(&frame)?;
                self.core.trace(|| TraceEvent::Sent(format!("{frame:<22} broadcast {b}")));
            }
            Transport::Rs232 { link, .. } => {
                let mut bytes = Vec::new();
                // `[cmd, param]` as on CAN, as the vendor's library sends it.
                rs232::encode(Direction::ToModule, 0, &b.payload(), &mut bytes);
                link.write_all(&bytes)?;
                self.core.trace(|| TraceEvent::Sent(format!("{} broadcast {b}", hex(&bytes))));
            }
        }
        Ok(())
    }

    /// Reads a parameter and decodes it by the table's type.
    pub fn get(&mut self, module: ModuleId, param: &ParamDef) -> Result<Value, SessionError> {
        let resp = self.transact(module, &Request::GetExtended { param: param.id })?;
        decode_get(module, param, &resp)
    }

    /// Writes a parameter; the caller has checked type and access.
    pub fn set(&mut self, module: ModuleId, param: &ParamDef, value: Value) -> Result<(), SessionError> {
        self.transact(module, &Request::set(param.id, value)).map(|_| ())
    }
}

impl PowerCube {
    /// Keeps the module watchdog refreshed from now on (CAN only; false on
    /// RS232, where nothing is sent): the broadcast `[0x07, 0]` goes out at
    /// once and then every `every` at the latest, from every send, every
    /// wait for an answer and [`Self::pause`], until [`Self::stop_refresh`].
    pub fn start_refresh(&mut self, every: Duration) -> Result<bool, SessionError> {
        let Transport::Can(link) = &mut self.transport else { return Ok(false) };
        let mut r = Refresh::new(Arc::clone(&self.core.clock), every);
        r.tick(&mut **link)?;
        let ms = every.as_secs_f64() * 1e3;
        self.core.trace(|| TraceEvent::Note(format!("watchdog refresh every {ms:.0} ms from here")));
        self.refresh = Some(r);
        Ok(true)
    }

    /// Stops the refresh; an online watchdog trips 50 ms after the last one.
    pub fn stop_refresh(&mut self) -> Option<RefreshStats> {
        let st = self.refresh.take()?.stats();
        let gap = st.max_gap.as_secs_f64() * 1e3;
        self.core.trace(|| {
            TraceEvent::Note(format!(
                "watchdog refresh stopped after {} refreshes, longest gap {gap:.1} ms",
                st.refreshes
            ))
        });
        Some(st)
    }

    /// Whether [`Self::start_refresh`] is in force.
    pub fn refreshing(&self) -> bool {
        self.refresh.is_some()
    }

    /// Sleeps `d` (woken early by a caught signal, as
    /// [`Clock::sleep_or_wake`](crate::clock::Clock::sleep_or_wake)),
    /// refreshing the watchdog meanwhile when that is in force: the pause
    /// between two polls of a wait.
    pub fn pause(&mut self, d: Duration) -> Result<(), SessionError> {
        let clock = Arc::clone(&self.core.clock);
        let end = clock.now() + d;
        loop {
            let now = clock.now();
            if now >= end {
                return Ok(());
            }
            let (Some(r), Transport::Can(link)) = (self.refresh.as_mut(), &mut self.transport) else {
                clock.sleep_or_wake(end - now);
                return Ok(());
            };
            r.tick(&mut **link)?;
            clock.sleep_or_wake(end.min(r.next()).saturating_duration_since(clock.now()));
            if crate::clock::stop::stop_requested() {
                return Ok(());
            }
        }
    }
}

fn target(module: ModuleId) -> String {
    format!("module {module}")
}

/// Refresh intervals of a keep-alive run, in microseconds.
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize)]
pub struct KeepaliveStats {
    pub refreshes: u64,
    pub interval_us: u64,
    pub min_gap_us: u64,
    pub mean_gap_us: u64,
    pub p99_gap_us: u64,
    pub max_gap_us: u64,
}

/// Gaps are binned by 10 µs up to this; longer ones count in the last bin
/// (the maximum is kept exactly).
const GAP_BINS: usize = 20_000;

/// A fixed-size histogram of gaps: recording allocates nothing, so the
/// refresh loop never waits on the allocator.
struct GapHistogram {
    bins: Box<[u32; GAP_BINS]>,
    n: u64,
    sum: u128,
    min: Duration,
    max: Duration,
}

impl GapHistogram {
    fn new() -> Self {
        Self { bins: Box::new([0; GAP_BINS]), n: 0, sum: 0, min: Duration::MAX, max: Duration::ZERO }
    }

    fn record(&mut self, gap: Duration) {
        let bin = ((gap.as_micros() / 10) as usize).min(GAP_BINS - 1);
        self.bins[bin] = self.bins[bin].saturating_add(1);
        self.n += 1;
        self.sum += gap.as_micros();
        self.min = self.min.min(gap);
        self.max = self.max.max(gap);
    }

    /// The upper edge of the bin holding the `q` quantile, capped at the maximum.
    fn quantile_us(&self, q: f64) -> u64 {
        if self.n == 0 {
            return 0;
        }
        let rank = ((self.n as f64) * q).ceil().max(1.0) as u64;
        let mut seen = 0u64;
        for (i, c) in self.bins.iter().enumerate() {
            seen += u64::from(*c);
            if seen >= rank {
                return ((i as u64 + 1) * 10).min(self.max.as_micros() as u64);
            }
        }
        self.max.as_micros() as u64
    }
}

impl PowerCube {
    /// Broadcasts the watchdog refresh `[0x07, 0]` every `interval` on an
    /// absolute schedule (a late turn does not push the later ones back) for
    /// as long as `keep_going` says, and measures the gaps between refreshes.
    /// Nothing in the loop allocates or takes a lock of ours.
    pub fn keepalive(
        &mut self,
        interval: Duration,
        keep_going: &mut dyn FnMut() -> bool,
    ) -> Result<KeepaliveStats, SessionError> {
        let clock = Arc::clone(&self.core.clock);
        let mut hist = GapHistogram::new();
        let mut next = clock.now();
        let mut last: Option<std::time::Instant> = None;
        while keep_going() {
            self.broadcast(Broadcast::WatchdogRefresh)?;
            let now = clock.now();
            if let Some(prev) = last {
                hist.record(now - prev);
            }
            last = Some(now);
            next += interval;
            let now = clock.now();
            if next > now {
                clock.sleep(next - now);
            } else {
                // Late: refresh at once and schedule from here.
                next = now;
            }
        }
        Ok(KeepaliveStats {
            refreshes: hist.n + u64::from(last.is_some()),
            interval_us: interval.as_micros() as u64,
            min_gap_us: if hist.n == 0 { 0 } else { hist.min.as_micros() as u64 },
            mean_gap_us: if hist.n == 0 { 0 } else { (hist.sum / u128::from(hist.n)) as u64 },
            p99_gap_us: hist.quantile_us(0.99),
            max_gap_us: hist.max.as_micros() as u64,
        })
    }
}

/// Decodes a GetExtended answer by the parameter's declared type.
pub fn decode_get(module: ModuleId, param: &ParamDef, resp: &Response) -> Result<Value, SessionError> {
    let Response::Get { data, .. } = resp else {
        return Err(SessionError::Malformed {
            target: target(module),
            source: DecodeError::Malformed(format!("expected a GetExtended answer, got {resp:?}")),
        });
    };
    Value::decode(param.ty, data.as_slice())
        .map_err(|source| SessionError::Malformed { target: target(module), source })
}

/// Wire time of `bytes` bytes at `baud` with 10 bits per byte (8N1).
pub fn rs232_wire_time(baud: u32, bytes: u32) -> Duration {
    Duration::from_micros(u64::from(bytes) * 10 * 1_000_000 / u64::from(baud.max(1)))
}

/// A short human description of a request, for traces and errors (its
/// `Display`; kept for the callers outside the session).
fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect::<Vec<_>>().join(" ")
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::clock::{Clock, VirtualClock};
    use crate::proto::powercube::can;
    use crate::proto::powercube::table::{ids, param, CommandId};
    use crate::sim::bench::in_process;

    // Manual 13 on the simulator: refreshes every 20 ms keep an online
    // watchdog quiet for as long as they run; 50 ms after the last one the
    // module stops with COMM_ERROR and HALTED, not a moment earlier.
    #[test]
    fn keepalive_holds_the_watchdog_and_its_end_trips_it_within_one_period() {
        use crate::proto::powercube::flags::{config, state};
        use crate::sim::bench::Bench;
        use crate::sim::shared::lock;
        let vclock = Arc::new(VirtualClock::new());
        let clock: Arc<dyn Clock> = vclock.clone();
        let bench = Bench::contract(Arc::clone(&clock));
        let mut pc = PowerCube::over_can(Box::new(bench.bus.open())).with_clock(Arc::clone(&clock));
        let m = ModuleId::new(5).unwrap();
        let cfg = match pc.get(m, param(ids::CONFIG).unwrap()).unwrap() {
            Value::UInt32(c) => c,
            other => panic!("{other:?}"),
        };
        pc.set(m, param(ids::CONFIG).unwrap(), Value::UInt32(cfg | config::WATCHDOG_ENABLE)).unwrap();
        pc.transact(m, &Request::Watchdog).unwrap();
        let state_at = |t: std::time::Instant| {
            let mut bus = lock(&bench.powercube);
            bus.advance(t);
            bus.module(5).unwrap().cube_state()
        };
        let start = clock.now();
        let mut last = start;
        let mut worst_state = 0;
        let stats = pc
            .keepalive(Duration::from_millis(20), &mut || {
                worst_state |= state_at(clock.now());
                last = clock.now();
                clock.now() - start < Duration::from_secs(3)
            })
            .unwrap();
        assert_eq!(worst_state & (state::COMM_ERROR | state::HALTED), 0, "never tripped while refreshed");
        assert_eq!((stats.min_gap_us, stats.max_gap_us, stats.p99_gap_us), (20_000, 20_000, 20_000));
        assert_eq!(stats.refreshes, 150, "0, 20, .., 2980 ms");
        // `last` is the check that ended the loop; the last refresh was 20 ms before.
        let refreshed = last - Duration::from_millis(20);
        assert_eq!(state_at(refreshed + Duration::from_micros(49_999)) & state::COMM_ERROR, 0);
        let s = state_at(refreshed + Duration::from_millis(50));
        assert_eq!(
            s & (state::COMM_ERROR | state::ERROR | state::HALTED),
            state::COMM_ERROR | state::ERROR | state::HALTED
        );
    }

    /// Modules of any id answering every GetExtended at once, with the
    /// count of reads so far (1.0, 2.0, ...) as the value; Halt is acknowledged.
    struct Counting(f32);

    impl crate::link::mem::CanDevice for Counting {
        fn on_frame(&mut self, _: std::time::Instant, frame: &CanFrame, out: &mut Vec<CanFrame>) {
            let (base, m, d) = (frame.id() & !0x1F, frame.id() & 0x1F, frame.data());
            match (base, d) {
                (can::GET_BASE, [0x0A, param]) => {
                    self.0 += 1.0;
                    let v = self.0.to_le_bytes();
                    out.push(CanFrame::new(can::ACK_BASE + m, &[0x0A, *param, v[0], v[1], v[2], v[3]]).unwrap());
                }
                (can::PUT_BASE, [0x02]) => out.push(CanFrame::new(can::ACK_BASE + m, &[0x02]).unwrap()),
                _ => {}
            }
        }
    }

    /// Every answer reaches the bus `after` its request: late enough that a
    /// burst's answers are still to come when the next burst goes out.
    struct Late(Duration);

    impl crate::link::mem::Fault for Late {
        fn device_frame(&mut self, frame: CanFrame, out: &mut Vec<crate::link::mem::Delivery>) {
            out.push(crate::link::mem::Delivery { after: self.0, frame });
        }
    }

    /// A session on a bus of [`Counting`] modules whose answers come 1 ms
    /// after the requests (timeout 100 ms), and the bus (to watch the requests).
    fn counting() -> (PowerCube, crate::link::mem::MemBus) {
        let clock: Arc<dyn Clock> = Arc::new(VirtualClock::new());
        let bus = crate::link::mem::MemBus::new(Arc::clone(&clock));
        bus.attach(Box::new(Counting(0.0)));
        bus.set_fault(Some(Box::new(Late(Duration::from_millis(1)))));
        (PowerCube::over_can(Box::new(bus.open())).with_clock(clock), bus)
    }

    fn act_pos(m: u8) -> (ModuleId, Request) {
        (ModuleId::new(m).unwrap(), Request::GetExtended { param: ids::ACT_POS })
    }

    fn values(answers: Vec<Result<Response, SessionError>>) -> Vec<f64> {
        answers
            .into_iter()
            .map(|a| decode_get(ModuleId::new(3).unwrap(), param(ids::ACT_POS).unwrap(), &a.unwrap()))
            .map(|v| v.unwrap().as_f64().unwrap())
            .collect()
    }

    // Two bursts go out before either is answered; each answer settles the
    // oldest request it answers, whichever burst is collected first, and a
    // request sent between the two takes its own answer.
    #[test]
    fn two_bursts_in_flight_take_their_answers_in_the_order_asked() {
        let (mut pc, bus) = counting();
        let mut watch = bus.open();
        let first = pc.send_burst(&[act_pos(3), act_pos(5)]).unwrap();
        let second = pc.send_burst(&[act_pos(3)]).unwrap();
        assert_eq!(pc.bursts_in_flight(), 2);
        let sent: Vec<String> =
            std::iter::from_fn(|| watch.recv(Duration::ZERO).unwrap()).map(|f| f.to_string()).collect();
        assert_eq!(sent, ["0C3#0A3C", "0C5#0A3C", "0C3#0A3C"], "both bursts out, no answer yet");
        let between = pc.get(ModuleId::new(3).unwrap(), param(ids::ACT_POS).unwrap()).unwrap();
        assert_eq!(between, Value::Float(4.0), "the fourth read asked");
        let later = pc.collect(second).unwrap();
        assert_eq!(values(later.answers), [3.0]);
        let earlier = pc.collect(first).unwrap();
        assert_eq!(values(earlier.answers), [1.0, 2.0]);
        assert!(earlier.first_answer.unwrap() <= later.first_answer.unwrap());
        assert_eq!(pc.bursts_in_flight(), 0);
    }

    // A burst given up before its answers came: they are dropped as they
    // come, not taken for the answer of the next read of the same value.
    #[test]
    fn the_answers_of_an_abandoned_burst_are_not_taken_by_the_next_request() {
        let (mut pc, _bus) = counting();
        let burst = pc.send_burst(&[act_pos(3), act_pos(3)]).unwrap();
        pc.abandon(burst);
        let m = ModuleId::new(3).unwrap();
        assert_eq!(pc.get(m, param(ids::ACT_POS).unwrap()).unwrap(), Value::Float(3.0));
        // A halt goes out at once past an abandoned burst and takes its own ack.
        let burst = pc.send_burst(&[act_pos(3)]).unwrap();
        pc.abandon(burst);
        let before = pc.clock().now();
        assert_eq!(pc.transact(m, &Request::Halt).unwrap(), Response::Simple(CommandId::Halt));
        assert!(pc.clock().now() - before < Duration::from_millis(2), "waited for the abandoned burst");
        assert_eq!(pc.get(m, param(ids::ACT_POS).unwrap()).unwrap(), Value::Float(5.0));
        assert_eq!(pc.bursts_in_flight(), 0, "answered abandoned bursts are forgotten");
    }

    // A request of a burst that nobody answers times out at the burst's
    // deadline; the others keep their answers.
    #[test]
    fn a_request_no_module_answers_times_out_in_its_burst() {
        let (mut pc, bus) = counting();
        bus.set_fault(Some(Box::new(DropModule5)));
        let burst = pc.send_burst(&[act_pos(3), act_pos(5), act_pos(17)]).unwrap();
        let got = pc.collect(burst).unwrap().answers;
        assert!(matches!(got[1], Err(SessionError::Timeout { .. })), "{got:?}");
        assert!(got[0].is_ok() && got[2].is_ok(), "{got:?}");
    }

    // A burst takes answers only until its deadline: a request it never got
    // an answer to must not take the answer to the same read asked later,
    // while the burst waits to be collected.
    #[test]
    fn a_burst_past_its_deadline_takes_no_answer() {
        let (mut pc, bus) = counting();
        bus.set_fault(Some(Box::new(DropModule5)));
        let first = pc.send_burst(&[act_pos(5)]).unwrap();
        let (m, req) = act_pos(5);
        assert!(matches!(pc.transact(m, &req), Err(SessionError::Timeout { .. })), "past the first's deadline");
        bus.set_fault(None);
        assert!(matches!(pc.transact(m, &req), Ok(Response::Get { .. })), "the answer is the request's own");
        let got = pc.collect(first).unwrap().answers;
        assert!(matches!(got[0], Err(SessionError::Timeout { .. })), "{got:?}");
    }

    // `--trace` says which burst each answer went to while another is
    // collected: the collected one's are its acks, the others' are kept.
    #[test]
    fn the_trace_tells_the_collected_bursts_answers_from_another_bursts() {
        let (mut pc, _bus) = counting();
        let notes = Arc::new(std::sync::Mutex::new(Vec::new()));
        let seen = Arc::clone(&notes);
        pc.set_tracer(Box::new(move |ev| {
            if let TraceEvent::Received(n) = ev {
                seen.lock().unwrap().push(n.split_whitespace().skip(1).collect::<Vec<_>>().join(" "));
            }
        }));
        let first = pc.send_burst(&[act_pos(5)]).unwrap();
        let second = pc.send_burst(&[act_pos(3)]).unwrap();
        assert_eq!(values(pc.collect(second).unwrap().answers), [2.0]);
        assert_eq!(*notes.lock().unwrap(), ["ack (to another burst in flight)", "ack"]);
        assert_eq!(values(pc.collect(first).unwrap().answers), [1.0]);
    }

    // `--trace` says when a burst is given up with answers still due.
    #[test]
    fn the_trace_says_how_many_answers_an_abandoned_burst_still_awaits() {
        let (mut pc, _bus) = counting();
        let notes = Arc::new(std::sync::Mutex::new(Vec::new()));
        let seen = Arc::clone(&notes);
        pc.set_tracer(Box::new(move |ev| {
            if let TraceEvent::Note(n) = ev {
                seen.lock().unwrap().push(n);
            }
        }));
        let answered = pc.send_burst(&[act_pos(3)]).unwrap();
        pc.get(ModuleId::new(5).unwrap(), param(ids::ACT_POS).unwrap()).unwrap();
        pc.abandon(answered);
        assert!(notes.lock().unwrap().is_empty(), "its answer came: nothing was due");
        let burst = pc.send_burst(&[act_pos(3), act_pos(5)]).unwrap();
        pc.abandon(burst);
        assert_eq!(*notes.lock().unwrap(), ["burst abandoned with 2 answers still due"]);
    }

    // The deadline belongs to the past: an answer that comes at the very
    // instant a burst's time is up is as late as one after it.
    #[test]
    fn an_answer_at_the_deadline_itself_is_late() {
        let (mut pc, bus) = counting();
        bus.set_fault(Some(Box::new(Late(pc.timeout()))));
        let burst = pc.send_burst(&[act_pos(5)]).unwrap();
        let got = pc.collect(burst).unwrap().answers;
        assert!(matches!(got[0], Err(SessionError::Timeout { .. })), "{got:?}");
    }

    struct DropModule5;

    impl crate::link::mem::Fault for DropModule5 {
        fn device_frame(&mut self, frame: CanFrame, out: &mut Vec<crate::link::mem::Delivery>) {
            if frame.id() != can::ACK_BASE + 5 {
                out.push(crate::link::mem::Delivery { after: Duration::ZERO, frame });
            }
        }
    }

    // Seen on a real kernel's vcan under qemu (scripts/qemu-socketcan.sh): a poll's ActPos
    // answer came after the timeout, the retry took it, and the retry's own answer stayed
    // queued, so every later read returned the previous poll's position.
    #[test]
    fn an_answer_queued_before_the_request_is_not_taken_for_its_answer() {
        let clock: Arc<dyn Clock> = Arc::new(VirtualClock::new());
        let bus = in_process(Arc::clone(&clock));
        let mut pc = PowerCube::over_can(Box::new(bus.open())).with_clock(Arc::clone(&clock));
        let m = ModuleId::new(3).unwrap();
        let act_pos = param(ids::ACT_POS).unwrap();
        // A late ActPos answer from an older exchange: 0.75, while module 3 stands at 0.
        let stale = CanFrame::new(0x0A3, &[0x0A, ids::ACT_POS, 0x00, 0x00, 0x40, 0x3F]).unwrap();
        bus.open().send(&stale).unwrap();
        assert_eq!(pc.get(m, act_pos).unwrap(), Value::Float(0.0));
    }
}
