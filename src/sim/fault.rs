//! Fault injection for the simulated bench: what a noisy bench does to the
//! answers of its devices, deterministic for a given seed.
//!
//! A [`FaultSpec`] (`drop=0.2,delay=150ms,garbage=0.1,...`, as `axisctl sim
//! --fault` takes it) says how often each fault hits an answer; an
//! [`Injector`] draws the decisions from a seeded generator, so a seed
//! replays the same faults for the same traffic. Faults hit what devices
//! send (answers and events), never what the host sends: a lost answer to a
//! motion command is the harder case (the device moved, the host cannot
//! know), and the one the "never resend motion" guarantee is about.
//!
//! - `drop=P`: the answer is lost.
//! - `delay=DUR[@P]`: the answer comes DUR late (every answer, or with
//!   probability P); beyond the timeout it lands in a later exchange.
//! - `garbage=P`: noise before the answer: 1..16 random bytes on a serial
//!   line, a frame of foreign traffic (ids 0x300..0x5FF, used by no family
//!   here) on CAN.
//! - `truncate=P`: the answer is cut short (a random number of bytes, or a
//!   shorter DLC on CAN).
//! - `duplicate=P`: the answer comes twice.
//! - `wrong-module=P`: the answer names another module: PowerCube
//!   acknowledges move to another module's id (CAN) or address (RS232),
//!   Cdios answers name another 6168 module. The PA-CONTROL has no address:
//!   there it changes nothing.
//! - `skip=N`: the first N answers pass untouched; `count=N`: at most N
//!   answers are hit.
//! - `trip=DUR`: a device that has been moving for DUR faults: a PowerCube
//!   module gets STATE_TOW_ERROR, a Cdios 6168 "motor does not run", a
//!   PA-CONTROL axis its limit switch (see [`Trip`]).
//!
//! Unplugging the adapter is not a fault here: end the serving process (or
//! drop the pty master) and the client's link reports it closed.

use std::collections::VecDeque;
use std::fmt;
use std::str::FromStr;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use super::shared::{lock, Shared};
use crate::family::Family;
use crate::link::mem::{ByteDevice, CanDevice, Delivery, Fault};
use crate::proto::CanFrame;

/// How often each fault hits an answer. The default injects nothing.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct FaultSpec {
    pub drop: f64,
    pub delay: Duration,
    /// Probability of `delay` (1 when `delay=DUR` has no `@P`).
    pub delay_p: f64,
    pub garbage: f64,
    pub truncate: f64,
    pub duplicate: f64,
    pub wrong_module: f64,
    pub skip: u64,
    pub count: Option<u64>,
    pub trip: Option<Duration>,
}

impl FaultSpec {
    /// Whether any answer can be touched (trips aside).
    pub fn touches_answers(&self) -> bool {
        let delayed = !self.delay.is_zero() && self.delay_p > 0.0;
        delayed || [self.drop, self.garbage, self.truncate, self.duplicate, self.wrong_module].iter().any(|p| *p > 0.0)
    }
}

/// `150ms`, `1.5s`, `2000us`, or plain milliseconds.
fn parse_duration(text: &str) -> Result<Duration, String> {
    let t = text.trim();
    let (num, scale) = if let Some(n) = t.strip_suffix("ms") {
        (n, 1e-3)
    } else if let Some(n) = t.strip_suffix("us") {
        (n, 1e-6)
    } else if let Some(n) = t.strip_suffix('s') {
        (n, 1.0)
    } else {
        (t, 1e-3)
    };
    let v: f64 = num.trim().parse().map_err(|_| format!("{text:?} is not a duration (e.g. 150ms or 1.5s)"))?;
    if !v.is_finite() || v < 0.0 || v * scale > 86_400.0 {
        return Err(format!("{text:?} is not a duration between 0 and a day"));
    }
    Ok(Duration::from_secs_f64(v * scale))
}

fn parse_probability(key: &str, text: &str) -> Result<f64, String> {
    match text.trim().parse::<f64>() {
        Ok(p) if (0.0..=1.0).contains(&p) => Ok(p),
        _ => Err(format!("{key}={text}: expected a probability 0..1")),
    }
}

impl FromStr for FaultSpec {
    type Err = String;

    fn from_str(text: &str) -> Result<Self, String> {
        let mut s = FaultSpec::default();
        for item in text.split(',').map(str::trim).filter(|i| !i.is_empty()) {
            let (key, value) =
                item.split_once('=').ok_or_else(|| format!("{item:?}: expected KEY=VALUE (e.g. drop=0.2)"))?;
            let count = |v: &str| v.trim().parse::<u64>().map_err(|_| format!("{key}={v}: expected a count"));
            match key.trim() {
                "drop" => s.drop = parse_probability(key, value)?,
                "garbage" => s.garbage = parse_probability(key, value)?,
                "truncate" => s.truncate = parse_probability(key, value)?,
                "duplicate" => s.duplicate = parse_probability(key, value)?,
                "wrong-module" => s.wrong_module = parse_probability(key, value)?,
                "delay" => {
                    let (d, p) = value.split_once('@').unwrap_or((value, "1"));
                    s.delay = parse_duration(d)?;
                    s.delay_p = parse_probability(key, p)?;
                }
                "skip" => s.skip = count(value)?,
                "count" => s.count = Some(count(value)?),
                "trip" => s.trip = Some(parse_duration(value)?),
                other => {
                    return Err(format!(
                        "unknown fault {other:?}: drop, delay, garbage, truncate, duplicate, wrong-module, \
                         skip, count or trip"
                    ))
                }
            }
        }
        Ok(s)
    }
}

impl fmt::Display for FaultSpec {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let mut parts = Vec::new();
        for (k, p) in [
            ("drop", self.drop),
            ("garbage", self.garbage),
            ("truncate", self.truncate),
            ("duplicate", self.duplicate),
            ("wrong-module", self.wrong_module),
        ] {
            if p > 0.0 {
                parts.push(format!("{k}={p}"));
            }
        }
        if !self.delay.is_zero() {
            parts.push(format!("delay={}ms@{}", self.delay.as_secs_f64() * 1e3, self.delay_p));
        }
        if self.skip > 0 {
            parts.push(format!("skip={}", self.skip));
        }
        if let Some(c) = self.count {
            parts.push(format!("count={c}"));
        }
        if let Some(t) = self.trip {
            parts.push(format!("trip={}ms", t.as_secs_f64() * 1e3));
        }
        f.write_str(&parts.join(","))
    }
}

/// SplitMix64: small, seedable, and the same on every platform.
#[derive(Debug, Clone)]
pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Self {
        Self(seed)
    }

    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in `[0, 1)`.
    pub fn unit(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }

    pub fn chance(&mut self, p: f64) -> bool {
        // Drawn even for p = 0, so that one fault's probability does not
        // shift the decisions of the others.
        self.unit() < p
    }

    /// Uniform in `lo..hi` (`lo` when empty).
    pub fn range(&mut self, lo: u64, hi: u64) -> u64 {
        if hi <= lo {
            lo
        } else {
            lo + self.next_u64() % (hi - lo)
        }
    }
}

/// What happens to one answer.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Plan {
    pub drop: bool,
    pub delay: Option<Duration>,
    pub garbage: bool,
    pub truncate: bool,
    pub duplicate: bool,
    pub wrong_module: bool,
}

impl Plan {
    fn any(&self) -> bool {
        self.drop || self.delay.is_some() || self.garbage || self.truncate || self.duplicate || self.wrong_module
    }
}

/// Counts of what was injected, for tests and the `sim` log.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct FaultStats {
    pub answers: u64,
    pub hit: u64,
    pub dropped: u64,
    pub delayed: u64,
    pub garbage: u64,
    pub truncated: u64,
    pub duplicated: u64,
    pub wrong_module: u64,
}

/// Draws a [`Plan`] per answer.
#[derive(Debug, Clone)]
pub struct Injector {
    spec: FaultSpec,
    rng: Rng,
    stats: FaultStats,
}

impl Injector {
    pub fn new(spec: FaultSpec, seed: u64) -> Self {
        Self { spec, rng: Rng::new(seed), stats: FaultStats::default() }
    }

    pub fn spec(&self) -> &FaultSpec {
        &self.spec
    }

    /// New faults from the next answer on (the generator runs on).
    pub fn set_spec(&mut self, spec: FaultSpec) {
        self.spec = spec;
        self.stats.hit = 0;
        self.stats.answers = 0;
    }

    pub fn stats(&self) -> FaultStats {
        self.stats
    }

    pub fn rng(&mut self) -> &mut Rng {
        &mut self.rng
    }

    /// The plan for the next answer.
    pub fn plan(&mut self) -> Plan {
        let s = self.spec;
        self.stats.answers += 1;
        let r = &mut self.rng;
        let drawn = Plan {
            drop: r.chance(s.drop),
            delay: (r.chance(s.delay_p) && !s.delay.is_zero()).then_some(s.delay),
            garbage: r.chance(s.garbage),
            truncate: r.chance(s.truncate),
            duplicate: r.chance(s.duplicate),
            wrong_module: r.chance(s.wrong_module),
        };
        let exhausted = s.count.is_some_and(|c| self.stats.hit >= c);
        if self.stats.answers <= s.skip || exhausted || !drawn.any() {
            return Plan::default();
        }
        let st = &mut self.stats;
        st.hit += 1;
        if drawn.drop {
            // A lost answer is lost: nothing else about it matters.
            st.dropped += 1;
            return Plan { drop: true, ..Plan::default() };
        }
        st.delayed += u64::from(drawn.delay.is_some());
        st.garbage += u64::from(drawn.garbage);
        st.truncated += u64::from(drawn.truncate);
        st.duplicated += u64::from(drawn.duplicate);
        st.wrong_module += u64::from(drawn.wrong_module);
        drawn
    }
}

/// Foreign traffic: an id no family on the bench uses.
fn foreign_frame(r: &mut Rng) -> CanFrame {
    let len = r.range(0, 9) as usize;
    let data: Vec<u8> = (0..len).map(|_| r.next_u64() as u8).collect();
    CanFrame::new(r.range(0x300, 0x600) as u32, &data).expect("standard id, <= 8 bytes")
}

/// Another device id than `current` in `lo..=hi` (the family's range: a
/// PowerCube module in 1..=31, a Cdios 6168 in 0..=15).
fn other(r: &mut Rng, current: u8, lo: u8, hi: u8) -> u8 {
    let span = u64::from(hi - lo) + 1;
    let k = r.range(1, span) as u8;
    lo + (current.wrapping_sub(lo).wrapping_add(k)) % (span as u8)
}

/// The answer as another device of its family sends it: each CAN family
/// of the registry says how its answers name their device.
fn wrong_module_frame(f: CanFrame, r: &mut Rng) -> CanFrame {
    Family::ALL.into_iter().find_map(|fam| fam.readdress_can(&f, &mut |cur, lo, hi| other(r, cur, lo, hi))).unwrap_or(f)
}

fn truncated_frame(f: CanFrame, r: &mut Rng) -> CanFrame {
    let len = f.data().len();
    if len == 0 {
        return f;
    }
    let keep = r.range(0, len as u64) as usize;
    CanFrame::new(f.id(), &f.data()[..keep]).unwrap_or(f)
}

/// The [`Fault`] of a [`MemBus`](crate::link::mem::MemBus): answers on the
/// simulated CAN bus.
pub struct CanFaults {
    inj: Arc<Mutex<Injector>>,
}

impl CanFaults {
    /// `inj` stays readable through the handle (stats).
    pub fn new(inj: Arc<Mutex<Injector>>) -> Self {
        Self { inj }
    }
}

impl Fault for CanFaults {
    fn device_frame(&mut self, frame: CanFrame, out: &mut Vec<Delivery>) {
        let mut inj = lock(&self.inj);
        let plan = inj.plan();
        if plan.drop {
            return;
        }
        let after = plan.delay.unwrap_or(Duration::ZERO);
        let r = inj.rng();
        if plan.garbage {
            out.push(Delivery { after, frame: foreign_frame(r) });
        }
        let mut f = frame;
        if plan.wrong_module {
            f = wrong_module_frame(f, r);
        }
        if plan.truncate {
            f = truncated_frame(f, r);
        }
        out.push(Delivery { after, frame: f });
        if plan.duplicate {
            out.push(Delivery { after, frame: f });
        }
    }
}

/// What a serial line carries, for `wrong-module`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ByteProtocol {
    /// PowerCube RS232: answers are re-framed from another module address.
    PowerCube,
    /// PA-CONTROL: one controller, no address.
    Pac,
}

impl ByteProtocol {
    /// The family whose protocol it is: the registry says how its serial
    /// answers name their device.
    pub fn family(self) -> Family {
        match self {
            Self::PowerCube => Family::PowerCube,
            Self::Pac => Family::Pac,
        }
    }
}

/// Faults on the answers of a device behind a serial line. Each chunk a
/// device writes in one go is one answer.
pub struct ByteFaults {
    inj: Arc<Mutex<Injector>>,
    protocol: ByteProtocol,
    delayed: VecDeque<(Instant, Vec<u8>)>,
}

impl ByteFaults {
    pub fn new(inj: Arc<Mutex<Injector>>, protocol: ByteProtocol) -> Self {
        Self { inj, protocol, delayed: VecDeque::new() }
    }

    /// Applies the faults to the answer in `out` (written at `now`): what is
    /// due at once stays in `out`, delayed bytes are kept for [`Self::due`].
    pub fn answer(&mut self, now: Instant, out: &mut Vec<u8>) {
        if out.is_empty() {
            return;
        }
        let mut inj = lock(&self.inj);
        let plan = inj.plan();
        if !plan.any() {
            return;
        }
        let r = inj.rng();
        let answer = std::mem::take(out);
        if plan.drop {
            return;
        }
        let mut bytes = Vec::with_capacity(answer.len() * 2 + 16);
        if plan.garbage {
            let n = r.range(1, 17);
            bytes.extend((0..n).map(|_| r.next_u64() as u8));
        }
        let mut body = answer;
        if plan.wrong_module {
            let pick = &mut |cur, lo, hi| other(r, cur, lo, hi);
            if let Some(b) = self.protocol.family().readdress_serial(&body, pick) {
                body = b;
            }
        }
        if plan.truncate && !body.is_empty() {
            let keep = r.range(0, body.len() as u64) as usize;
            body.truncate(keep);
        }
        bytes.extend_from_slice(&body);
        if plan.duplicate {
            bytes.extend_from_slice(&body);
        }
        match plan.delay {
            Some(d) => self.delayed.push_back((now + d, bytes)),
            None => *out = bytes,
        }
    }

    /// Appends the delayed answers due by `now`.
    pub fn due(&mut self, now: Instant, out: &mut Vec<u8>) {
        while self.delayed.front().is_some_and(|(t, _)| *t <= now) {
            let (_, bytes) = self.delayed.pop_front().expect("checked");
            out.extend_from_slice(&bytes);
        }
    }
}

/// A [`ByteDevice`] whose answers go through [`ByteFaults`] (for
/// [`MemByteLink`](crate::link::mem::MemByteLink)).
pub struct FaultyByteDevice<D> {
    device: D,
    faults: ByteFaults,
    scratch: Vec<u8>,
}

impl<D: ByteDevice> FaultyByteDevice<D> {
    pub fn new(device: D, faults: ByteFaults) -> Self {
        Self { device, faults, scratch: Vec::new() }
    }
}

impl<D: ByteDevice> ByteDevice for FaultyByteDevice<D> {
    fn on_bytes(&mut self, now: Instant, bytes: &[u8], out: &mut Vec<u8>) {
        self.device.on_bytes(now, bytes, &mut self.scratch);
        self.faults.answer(now, &mut self.scratch);
        out.append(&mut self.scratch);
    }

    fn poll(&mut self, now: Instant, out: &mut Vec<u8>) {
        self.device.poll(now, &mut self.scratch);
        self.faults.answer(now, &mut self.scratch);
        out.append(&mut self.scratch);
        self.faults.due(now, out);
    }
}

/// A simulated family as `trip=` sees it, implemented beside each
/// simulator: which of its devices move, and the fault one gets when its
/// load jams (a PowerCube module STATE_TOW_ERROR, a Cdios 6168 "motor does
/// not run", a PA-CONTROL axis its limit switch).
pub trait Jams: Send {
    /// Every device by its id, and whether it moves at `now`.
    fn moving(&mut self, now: Instant) -> Vec<(u8, bool)>;
    /// Faults device `id` as its load jamming does.
    fn jam(&mut self, now: Instant, id: u8);
}

/// `trip=DUR`: faults a device that has been moving for `after`, as a real
/// module does when its load jams. Each device trips once per motion.
pub struct Trip {
    after: Duration,
    watched: Vec<Shared<dyn Jams>>,
    /// (index in `watched`, id) -> moving since.
    moving: Vec<(usize, u8, Instant)>,
}

impl Trip {
    pub fn new(after: Duration) -> Self {
        Self { after, watched: Vec::new(), moving: Vec::new() }
    }

    /// Watches the devices of one simulator too.
    pub fn watch(mut self, sim: Shared<dyn Jams>) -> Self {
        self.watched.push(sim);
        self
    }

    /// True when `(sim, id)` has moved for `after` by `now`; forgets it
    /// once it stands.
    fn due(&mut self, sim: usize, id: u8, moving: bool, now: Instant) -> bool {
        let at = self.moving.iter().position(|(s, i, _)| (*s, *i) == (sim, id));
        match (moving, at) {
            (false, Some(k)) => {
                self.moving.swap_remove(k);
                false
            }
            (false, None) => false,
            (true, None) => {
                self.moving.push((sim, id, now));
                self.after.is_zero()
            }
            (true, Some(k)) => now.saturating_duration_since(self.moving[k].2) >= self.after,
        }
    }

    /// Looks at every device at `now` and faults the ones due.
    pub fn check(&mut self, now: Instant) {
        for (k, sim) in self.watched.clone().iter().enumerate() {
            let mut sim = lock(sim);
            for (id, moving) in sim.moving(now) {
                if self.due(k, id, moving, now) {
                    sim.jam(now, id);
                }
            }
        }
    }
}

/// On the bus, a [`Trip`] looks at the devices whenever the bus runs.
impl CanDevice for Trip {
    fn on_frame(&mut self, now: Instant, _frame: &CanFrame, _out: &mut Vec<CanFrame>) {
        self.check(now);
    }

    fn poll(&mut self, now: Instant, _out: &mut Vec<CanFrame>) {
        self.check(now);
    }
}

#[cfg(test)]
mod tests;
