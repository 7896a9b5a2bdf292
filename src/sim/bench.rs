//! The simulated bench: the devices of `cli-contract.md` on one in-memory
//! CAN bus (PowerCube modules 3, 5 and 17, 17 linear; Cdios node 1 with 6168
//! modules 0 and 1; their CAN ids do not overlap) and a PA-CONTROL with 3
//! axes on its own serial line, shared by the in-process `--link sim` and by
//! `axisctl sim`'s served links.

use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use super::cdios::CdiosNode;
use super::fault::{ByteFaults, CanFaults, FaultSpec, FaultyByteDevice, Injector, Trip};
use super::pac::PacController;
use super::powercube::{ModuleKind, ModuleSpec, PowerCubeBus};
use super::shared::{lock, Shared};
use crate::clock::Clock;
use crate::family::Family;
use crate::link::mem::{ByteDevice, CanDevice, MemBus, MemByteLink};
use crate::link::SimStart;
use crate::proto::cdios::NodeId;
use crate::proto::powercube::ModuleId;
use crate::proto::CanFrame;

/// What the bench holds.
#[derive(Debug, Clone)]
pub struct BenchConfig {
    pub modules: Vec<u8>,
    pub linear: Vec<u8>,
    /// Cdios node id (1..127; anything else means the factory setting 1).
    pub node: u8,
    /// Cdios 6168 module ids (0..15).
    pub cdios_modules: Vec<u8>,
    /// PA-CONTROL axes (1..=16).
    pub axes: u8,
}

impl Default for BenchConfig {
    /// The contract's bench.
    fn default() -> Self {
        Self {
            modules: vec![3, 5, 17],
            linear: vec![17],
            node: NodeId::FACTORY.get(),
            cdios_modules: vec![0, 1],
            axes: 3,
        }
    }
}

impl BenchConfig {
    pub fn module_specs(&self) -> Vec<ModuleSpec> {
        self.modules
            .iter()
            .filter_map(|&id| ModuleId::new(id))
            .map(|id| {
                ModuleSpec::new(
                    id,
                    if self.linear.contains(&id.get()) { ModuleKind::Linear } else { ModuleKind::Rotary },
                )
            })
            .collect()
    }
}

struct SharedPowerCube(Shared<PowerCubeBus>);

impl CanDevice for SharedPowerCube {
    fn on_frame(&mut self, now: Instant, frame: &CanFrame, out: &mut Vec<CanFrame>) {
        lock(&self.0).handle_can(now, frame, out);
    }
}

struct SharedCdios(Shared<CdiosNode>);

impl CanDevice for SharedCdios {
    fn on_frame(&mut self, now: Instant, frame: &CanFrame, out: &mut Vec<CanFrame>) {
        lock(&self.0).handle_can(now, frame, out);
    }

    fn poll(&mut self, now: Instant, out: &mut Vec<CanFrame>) {
        lock(&self.0).poll(now, out);
    }
}

/// Line speeds of the in-process bench (`AXISCTL_SIM_WIRE_SPEED`), so that
/// `--link sim` runs at the physical limit as `axisctl sim --wire-speed` does.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct WireSpeed {
    /// The PA-CONTROL's serial line (7N1).
    pub baud: u32,
    /// The CAN bus.
    pub bitrate: u32,
}

impl Default for WireSpeed {
    fn default() -> Self {
        Self { baud: 9600, bitrate: 1_000_000 }
    }
}

impl WireSpeed {
    pub const ENV: &'static str = "AXISCTL_SIM_WIRE_SPEED";

    /// Empty or `0`: off. `1`: 9600 baud and 1 Mbit/s. `baud=N,bitrate=N`:
    /// either or both (the other at its default).
    pub fn parse(text: &str) -> Result<Option<Self>, String> {
        let text = text.trim();
        match text {
            "" | "0" => return Ok(None),
            "1" => return Ok(Some(Self::default())),
            _ => {}
        }
        let mut ws = Self::default();
        for pair in text.split(',').map(str::trim) {
            let bad = || format!("{}={text:?}: expected 0, 1 or baud=N,bitrate=N", Self::ENV);
            let (k, v) = pair.split_once('=').ok_or_else(bad)?;
            let v: u32 = v.trim().parse().ok().filter(|v| *v > 0).ok_or_else(bad)?;
            match k.trim() {
                "baud" => ws.baud = v,
                "bitrate" => ws.bitrate = v,
                _ => return Err(bad()),
            }
        }
        Ok(Some(ws))
    }

    pub fn from_env() -> Result<Option<Self>, String> {
        std::env::var(Self::ENV).map_or(Ok(None), |v| Self::parse(&v))
    }
}

/// The PowerCube modules' RS232 side as a byte device.
pub struct PowerCubeRs232(pub Shared<PowerCubeBus>);

impl ByteDevice for PowerCubeRs232 {
    fn on_bytes(&mut self, now: Instant, bytes: &[u8], out: &mut Vec<u8>) {
        lock(&self.0).handle_rs232(now, bytes, out);
    }
}

pub struct Bench {
    pub bus: MemBus,
    pub powercube: Shared<PowerCubeBus>,
    pub cdios: Shared<CdiosNode>,
    /// The PA-CONTROL, reached over [`Bench::pac_link`] or a served pty.
    pub pac: Shared<PacController>,
    wire: Option<WireSpeed>,
}

impl Bench {
    pub fn new(cfg: &BenchConfig, clock: Arc<dyn Clock>) -> Self {
        let now = clock.now();
        let bus = MemBus::new(clock);
        let powercube = Arc::new(Mutex::new(PowerCubeBus::new(cfg.module_specs(), now)));
        bus.attach(Box::new(SharedPowerCube(Arc::clone(&powercube))));
        let node = NodeId::new(cfg.node).unwrap_or(NodeId::FACTORY);
        let cdios = Arc::new(Mutex::new(CdiosNode::new(node, &cfg.cdios_modules, now)));
        bus.attach(Box::new(SharedCdios(Arc::clone(&cdios))));
        let pac = Arc::new(Mutex::new(PacController::new(cfg.axes, now)));
        Self { bus, powercube, cdios, pac, wire: None }
    }

    /// Runs the bus and the links opened from now on at `wire` speeds (`None`: instantly).
    pub fn set_wire_speed(&mut self, wire: Option<WireSpeed>) {
        self.bus.set_bitrate(wire.map(|w| w.bitrate));
        self.wire = wire;
    }

    /// A serial line to the PA-CONTROL (the in-process `--link sim`); every
    /// link opened here talks to the same controller.
    pub fn pac_link(&self, clock: Arc<dyn Clock>) -> MemByteLink {
        let mut link = MemByteLink::new(Box::new(Arc::clone(&self.pac)), clock);
        if let Some(w) = self.wire {
            let bits = Family::Pac.serial_default().map_or(10, |d| d.format.bits_per_char());
            link.set_char_time(Duration::from_secs(bits.into()) / w.baud);
        }
        link
    }

    /// Faults on the CAN bus (the answers of every device on it) and, with
    /// `trip`, a watcher that faults moving PowerCube and Cdios devices;
    /// `overshoot` and `slow-halt` change the response of the PowerCube
    /// modules (on every link to them: CAN and RS232 reach the same
    /// modules) and of the PA-CONTROL axes.
    /// Returns the injector (its stats count what was hit).
    pub fn inject_faults(&self, spec: FaultSpec, seed: u64) -> Shared<Injector> {
        let inj = Arc::new(Mutex::new(Injector::new(spec, seed)));
        if spec.touches_answers() {
            self.bus.set_fault(Some(Box::new(CanFaults::new(Arc::clone(&inj)))));
        }
        if let Some(after) = spec.trip {
            let trip = Trip::new(after).watch(self.powercube.clone()).watch(self.cdios.clone());
            self.bus.attach(Box::new(trip));
        }
        if spec.overshoot > 0.0 || spec.slow_halt.is_some() {
            let fault = super::powercube::ResponseFault {
                overshoot: spec.overshoot / 100.0,
                halt_time: spec.slow_halt.map_or(0.0, |d| d.as_secs_f64()),
            };
            lock(&self.powercube).modules_mut().for_each(|m| m.set_response_fault(fault));
            lock(&self.pac).set_response_fault(fault);
        }
        inj
    }

    /// The PowerCube modules as a byte device at the far end of an RS232 line.
    pub fn powercube_port(&self) -> PowerCubeRs232 {
        PowerCubeRs232(Arc::clone(&self.powercube))
    }

    /// An RS232 line to the PowerCube modules (the same modules as on the
    /// bus), its answers through `faults` if given.
    pub fn powercube_rs232_link(&self, clock: Arc<dyn Clock>, faults: Option<ByteFaults>) -> MemByteLink {
        let port = PowerCubeRs232(Arc::clone(&self.powercube));
        match faults {
            Some(f) => MemByteLink::new(Box::new(FaultyByteDevice::new(port, f)), clock),
            None => MemByteLink::new(Box::new(port), clock),
        }
    }

    /// A serial line to the PA-CONTROL whose answers go through `faults`.
    pub fn faulty_pac_link(&self, clock: Arc<dyn Clock>, faults: ByteFaults) -> MemByteLink {
        MemByteLink::new(Box::new(FaultyByteDevice::new(Arc::clone(&self.pac), faults)), clock)
    }

    /// Puts the bench in `start`'s state through the devices' own inputs,
    /// as a client would (each simulator says how: [`PacController::start`],
    /// [`CdiosNode::enable_all`]).
    pub fn start(&self, now: Instant, start: SimStart) {
        lock(&self.pac).start(now, start.pac);
        if start.cdios_enabled {
            lock(&self.cdios).enable_all(now);
        }
    }

    pub fn contract(clock: Arc<dyn Clock>) -> Self {
        Self::new(&BenchConfig::default(), clock)
    }
}

/// The in-process bench behind `--link sim`.
pub fn in_process(clock: Arc<dyn Clock>) -> MemBus {
    Bench::contract(clock).bus
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::clock::VirtualClock;
    use crate::link::ByteLink;
    use crate::proto::pac::{AckDecoder, Command, Par2};

    fn transact(link: &mut MemByteLink, bytes: &[u8]) -> crate::proto::pac::Ack {
        link.write_all(bytes).unwrap();
        let mut buf = [0u8; 256];
        let n = link.read(&mut buf, Duration::from_millis(100)).unwrap();
        let mut dec = AckDecoder::new();
        dec.push(&buf[..n]);
        dec.next().expect("an acknowledge").unwrap()
    }

    // The in-process `--link sim` path: a 0A87 move polled on virtual time.
    #[test]
    fn pac_link_reaches_the_shared_controller_on_virtual_time() {
        let clock = Arc::new(VirtualClock::new());
        let bench = Bench::contract(clock.clone());
        let mut link = bench.pac_link(clock.clone());
        assert_eq!(transact(&mut link, &Command::new(0x0603, 0, Par2::Int(0)).encode().unwrap()).status, 31);
        transact(&mut link, &Command::new(0x0A96, 3, Par2::Float(0.0)).encode().unwrap());
        let first = transact(&mut link, &Command::new(0x0A87, 3, Par2::Float(2000.0)).encode().unwrap());
        assert!(!first.be);
        let t0 = clock.now();
        let mut polls = 0;
        while !transact(&mut link, &[0x04]).be {
            polls += 1;
            clock.advance(Duration::from_millis(50));
        }
        // 2000 AE at 1000 AE/s and 2000 AE/s²: 2.5 s.
        assert_eq!(clock.now() - t0, Duration::from_millis(2500));
        assert_eq!(polls, 50);
        assert_eq!(lock(&bench.pac).axis_position(3), Some(2000.0));
        let mut other = bench.pac_link(clock);
        let pos = transact(&mut other, &Command::new(0x190C, 3, Par2::Float(0.0)).encode().unwrap());
        assert_eq!(pos.q_par, Par2::Float(2000.0), "every link reaches the same controller");
    }

    #[test]
    fn wire_speed_from_its_variable() {
        assert_eq!(WireSpeed::parse(""), Ok(None));
        assert_eq!(WireSpeed::parse("0"), Ok(None));
        assert_eq!(WireSpeed::parse("1"), Ok(Some(WireSpeed { baud: 9600, bitrate: 1_000_000 })));
        assert_eq!(WireSpeed::parse("baud=19200"), Ok(Some(WireSpeed { baud: 19200, bitrate: 1_000_000 })));
        assert_eq!(
            WireSpeed::parse("bitrate=500000, baud=38400"),
            Ok(Some(WireSpeed { baud: 38400, bitrate: 500_000 }))
        );
        for bad in ["yes", "baud=0", "baud=x", "speed=1", "baud"] {
            assert!(WireSpeed::parse(bad).unwrap_err().contains(WireSpeed::ENV), "{bad}");
        }
    }

    // 0x190C get-actual-pos on the in-process line at 9600 baud 7N1: the
    // command's and the acknowledge's characters at 9 bits each.
    #[test]
    fn pac_link_at_wire_speed_takes_the_characters_time() {
        let clock = Arc::new(VirtualClock::new());
        let mut bench = Bench::contract(clock.clone());
        bench.set_wire_speed(Some(WireSpeed::default()));
        let mut link = bench.pac_link(clock.clone());
        let request = Command::new(0x190C, 3, Par2::Float(0.0)).encode().unwrap();
        let t0 = clock.now();
        link.write_all(&request).unwrap();
        let mut answer = Vec::new();
        let mut buf = [0u8; 64];
        while answer.last() != Some(&0x04) {
            let n = link.read(&mut buf, Duration::from_millis(200)).unwrap();
            assert!(n > 0, "no acknowledge");
            answer.extend_from_slice(&buf[..n]);
        }
        let chars = (request.len() + answer.len()) as u32;
        let wire = Duration::from_secs(9) * chars / 9600;
        let took = clock.now() - t0;
        assert!(took >= wire && took <= wire + Duration::from_micros(chars.into()), "{took:?} for {chars} chars");
    }
}
