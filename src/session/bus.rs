//! One CAN link shared by the sessions of several families (PowerCube and
//! Cdios on one bus): every frame read is routed to the family whose
//! answer it is, so a frame one session reads while it waits reaches the
//! session it belongs to instead of being dropped.
//!
//! Each session gets a [`BusPort`] (a [`CanLink`]). A port receives its own
//! queue first; then it reads the shared link and keeps what is its own,
//! queueing other families' answers for their ports. Frames that are nobody's
//! answers (requests of another master, NMT) and answers of a family without
//! a port go to the port that read them, as on a link of its own.
//!
//! The shared link is locked for the length of one `recv`: meant for sessions
//! driven one transaction at a time (the dashboard's link worker), where the
//! lock is never contended.

use std::collections::VecDeque;
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::Duration;

use crate::clock::Clock;
use crate::family::Family;
use crate::link::{CanLink, LinkError};
use crate::proto::CanFrame;

/// Answers kept for a port that does not read; older ones are dropped.
pub const PORT_QUEUE: usize = 1024;

/// The family whose answer `frame` is, by its id; `None` for frames that
/// answer nobody (requests of another master, NMT). Each family says which
/// ids are its answers in the registry, so a new CAN family is routed
/// without a change here.
pub fn family_of(frame: &CanFrame) -> Option<Family> {
    Family::of_can_answer(frame)
}

struct Port {
    family: Family,
    queue: VecDeque<CanFrame>,
    dropped: u64,
}

struct Shared {
    link: Box<dyn CanLink>,
    ports: Vec<Port>,
}

impl Shared {
    /// Queues `frame` for every port of its route but `reader`; whether
    /// `reader` takes it itself.
    fn route(&mut self, reader: usize, frame: CanFrame) -> bool {
        let Some(family) = family_of(&frame) else { return true };
        if !self.ports.iter().any(|p| p.family == family) {
            return true;
        }
        for (i, p) in self.ports.iter_mut().enumerate() {
            if i != reader && p.family == family {
                if p.queue.len() >= PORT_QUEUE {
                    p.queue.pop_front();
                    p.dropped += 1;
                }
                p.queue.push_back(frame);
            }
        }
        self.ports[reader].family == family
    }
}

/// The shared link. Cheap to clone; clones share it.
#[derive(Clone)]
pub struct CanBus {
    shared: Arc<Mutex<Shared>>,
    clock: Arc<dyn Clock>,
}

impl CanBus {
    /// `clock`: what receive timeouts are measured on (the link's).
    pub fn new(link: Box<dyn CanLink>, clock: Arc<dyn Clock>) -> Self {
        Self { shared: Arc::new(Mutex::new(Shared { link, ports: Vec::new() })), clock }
    }

    /// A new port receiving `family`'s answers.
    pub fn port(&self, family: Family) -> BusPort {
        let mut s = self.lock();
        s.ports.push(Port { family, queue: VecDeque::new(), dropped: 0 });
        BusPort { bus: self.clone(), index: s.ports.len() - 1 }
    }

    fn lock(&self) -> MutexGuard<'_, Shared> {
        // A panic elsewhere leaves the queues consistent: every change is one push or pop.
        self.shared.lock().unwrap_or_else(|e| e.into_inner())
    }
}

/// One session's view of a [`CanBus`].
pub struct BusPort {
    bus: CanBus,
    index: usize,
}

impl BusPort {
    /// Answers dropped because this port's queue was full.
    pub fn dropped(&self) -> u64 {
        self.bus.lock().ports[self.index].dropped
    }
}

impl CanLink for BusPort {
    fn send(&mut self, frame: &CanFrame) -> Result<(), LinkError> {
        self.bus.lock().link.send(frame)
    }

    fn send_many(&mut self, frames: &[CanFrame]) -> Result<(), LinkError> {
        self.bus.lock().link.send_many(frames)
    }

    fn recv(&mut self, timeout: Duration) -> Result<Option<CanFrame>, LinkError> {
        let deadline = self.bus.clock.now() + timeout;
        let mut s = self.bus.lock();
        loop {
            if let Some(f) = s.ports[self.index].queue.pop_front() {
                return Ok(Some(f));
            }
            let left = deadline.saturating_duration_since(self.bus.clock.now());
            let Some(frame) = s.link.recv(left)? else { return Ok(None) };
            if s.route(self.index, frame) {
                return Ok(Some(frame));
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use std::time::Instant;

    use super::*;
    use crate::clock::VirtualClock;
    use crate::link::mem::{CanDevice, MemBus};
    use crate::proto::cdios::{ModuleId as CdiosModule, NodeId, PositionSource};
    use crate::proto::powercube::table::{ids, param};
    use crate::proto::powercube::{frame::Value, ModuleId};
    use crate::session::cdios::Cdios;
    use crate::session::powercube::PowerCube;

    fn f(s: &str) -> CanFrame {
        s.parse().unwrap()
    }

    #[test]
    fn routes_by_answer_id() {
        assert_eq!(family_of(&f("0A3#0A3C")), Some(Family::PowerCube));
        assert_eq!(family_of(&f("181#6600000000800000")), Some(Family::Cdios));
        for nobody in ["0C3#0A3C", "201#2100000000000000", "000#0101", "100#0700", "0A0#00", "180#00"] {
            assert_eq!(family_of(&f(nobody)), None, "{nobody}");
        }
    }

    // On a bus with one family's port, another family's answers are that
    // port's to read, as on a link of its own (a monitor-like reader).
    #[test]
    fn a_family_without_a_port_is_read_by_whoever_reads() {
        let clock: Arc<dyn Clock> = Arc::new(VirtualClock::new());
        let mem = MemBus::new(Arc::clone(&clock));
        let bus = CanBus::new(Box::new(mem.open()), Arc::clone(&clock));
        let mut cube = bus.port(Family::PowerCube);
        let event = f("181#6100007B00000000");
        mem.open().send(&event).unwrap();
        assert_eq!(cube.recv(Duration::from_millis(10)).unwrap(), Some(event));
    }

    // A port nobody reads keeps the newest PORT_QUEUE answers and counts
    // what it had to drop.
    #[test]
    fn a_port_that_does_not_read_drops_its_oldest_answers_and_counts_them() {
        let clock: Arc<dyn Clock> = Arc::new(VirtualClock::new());
        let mem = MemBus::new(Arc::clone(&clock));
        let bus = CanBus::new(Box::new(mem.open()), Arc::clone(&clock));
        let mut cube = bus.port(Family::PowerCube);
        let mut cdios = bus.port(Family::Cdios);
        let mut sender = mem.open();
        let extra = 3;
        for i in 0..PORT_QUEUE + extra {
            let pos = (i as u32).to_le_bytes();
            sender.send(&CanFrame::new(0x181, &[0x61, 0, 0, pos[0], pos[1], pos[2], pos[3], 0]).unwrap()).unwrap();
        }
        // The PowerCube port reads the bus dry: every frame is Cdios's.
        assert_eq!(cube.recv(Duration::from_millis(10)).unwrap(), None);
        assert_eq!(cdios.dropped(), extra as u64);
        let first = cdios.recv(Duration::ZERO).unwrap().unwrap();
        assert_eq!(first.data()[3], extra as u8, "the oldest were dropped");
        assert_eq!(cube.dropped(), 0);
    }

    /// Module 3 answers ActPos = 0.75, and the first time a Cdios node 1
    /// sends a position event just before, so that the PowerCube session
    /// reads it while it waits for its answer.
    struct CubeWithChattyNeighbour(bool);

    impl CanDevice for CubeWithChattyNeighbour {
        fn on_frame(&mut self, _now: Instant, frame: &CanFrame, out: &mut Vec<CanFrame>) {
            match frame.id() {
                0x0C3 => {
                    if !std::mem::replace(&mut self.0, true) {
                        out.push(f("181#6100007B00000000"));
                    }
                    out.push(f("0A3#0A3C0000403F"));
                }
                // 21h current position of module 0: -1200.
                0x201 => out.push(f("181#21000050FBFFFF00")),
                _ => {}
            }
        }
    }

    // With each session dropping the other family's frames, the event read
    // by the PowerCube session was lost to the Cdios session.
    #[test]
    fn a_cdios_event_read_while_powercube_waits_reaches_the_cdios_session() {
        let clock: Arc<dyn Clock> = Arc::new(VirtualClock::new());
        let mem = MemBus::new(Arc::clone(&clock));
        mem.attach(Box::new(CubeWithChattyNeighbour(false)));
        let bus = CanBus::new(Box::new(mem.open()), Arc::clone(&clock));
        let mut pc = PowerCube::over_can(Box::new(bus.port(Family::PowerCube))).with_clock(Arc::clone(&clock));
        let mut cd = Cdios::new(Box::new(bus.port(Family::Cdios))).with_clock(Arc::clone(&clock));
        cd.set_nmt(false);
        let act_pos = param(ids::ACT_POS).unwrap();
        assert_eq!(pc.get(ModuleId::new(3).unwrap(), act_pos).unwrap(), Value::Float(0.75));
        let node = NodeId::new(1).unwrap();
        let m0 = CdiosModule::new(0).unwrap();
        assert_eq!(cd.read_position(node, m0, PositionSource::Current).unwrap(), -1200);
        let events = cd.take_events();
        assert_eq!(events.len(), 1, "{events:?}");
        assert_eq!(events[0].decoded().unwrap().get("position"), Some(123));
        // The PowerCube session is not disturbed by what the Cdios one reads.
        assert_eq!(pc.get(ModuleId::new(3).unwrap(), act_pos).unwrap(), Value::Float(0.75));
    }

    #[test]
    fn a_zero_timeout_returns_only_what_is_queued() {
        let clock: Arc<dyn Clock> = Arc::new(VirtualClock::new());
        let mem = MemBus::new(Arc::clone(&clock));
        let mut other = mem.open();
        let bus = CanBus::new(Box::new(mem.open()), Arc::clone(&clock));
        let mut cube = bus.port(Family::PowerCube);
        let mut cdios = bus.port(Family::Cdios);
        for s in ["181#21", "0A3#00", "201#21", "182#26"] {
            other.send(&f(s)).unwrap();
        }
        let t0 = clock.now();
        assert_eq!(cube.recv(Duration::ZERO).unwrap(), Some(f("0A3#00")));
        assert_eq!(cube.recv(Duration::ZERO).unwrap(), Some(f("201#21")), "nobody's frame: the reader's");
        assert_eq!(cube.recv(Duration::ZERO).unwrap(), None);
        assert_eq!(cdios.recv(Duration::ZERO).unwrap(), Some(f("181#21")));
        assert_eq!(cdios.recv(Duration::ZERO).unwrap(), Some(f("182#26")));
        assert_eq!(cdios.recv(Duration::from_millis(5)).unwrap(), None);
        assert_eq!(clock.now() - t0, Duration::from_millis(5));
    }

    proptest::proptest! {
        // Whichever port reads first, every frame arrives exactly once, each
        // family's answers at its own port in bus order.
        #[test]
        fn every_frame_reaches_exactly_one_port_in_order(
            ids in proptest::collection::vec(proptest::sample::select(vec![0x0A3u32, 0x0B1, 0x181, 0x1FF, 0x0C3, 0x201, 0x000]), 0..40),
            readers in proptest::collection::vec(proptest::bool::ANY, 0..80),
        ) {
            let clock: Arc<dyn Clock> = Arc::new(VirtualClock::new());
            let mem = MemBus::new(Arc::clone(&clock));
            let mut other = mem.open();
            let bus = CanBus::new(Box::new(mem.open()), Arc::clone(&clock));
            let mut ports = [bus.port(Family::PowerCube), bus.port(Family::Cdios)];
            let sent: Vec<CanFrame> = ids.iter().enumerate().map(|(i, id)| CanFrame::new(*id, &[i as u8]).unwrap()).collect();
            for frame in &sent {
                other.send(frame).unwrap();
            }
            let mut got: [Vec<CanFrame>; 2] = [Vec::new(), Vec::new()];
            // Interleaved single reads, then each port drained.
            for r in readers.iter().map(|r| usize::from(*r)) {
                got[r].extend(ports[r].recv(Duration::ZERO).unwrap());
            }
            for r in [0, 1] {
                while let Some(frame) = ports[r].recv(Duration::ZERO).unwrap() {
                    got[r].push(frame);
                }
            }
            for (r, route) in [Family::PowerCube, Family::Cdios].into_iter().enumerate() {
                let own: Vec<_> = got[r].iter().filter(|f| family_of(f).is_some()).copied().collect();
                let expected: Vec<_> = sent.iter().filter(|f| family_of(f) == Some(route)).copied().collect();
                proptest::prop_assert_eq!(own, expected);
            }
            let mut all: Vec<_> = got.concat();
            all.sort_by_key(|f| f.data()[0]);
            proptest::prop_assert_eq!(all, sent);
        }
    }
}
