//! The simulated bench: the devices of `cli-contract.md` on one in-memory
//! CAN bus (PowerCube modules 3, 5 and 17, 17 linear; Cdios node 1 with 6168
//! modules 0 and 1; their CAN ids do not overlap), shared by the in-process
//! `--link sim` and by `axisctl sim`'s served links.

use std::sync::{Arc, Mutex, MutexGuard};
use std::time::Instant;

use super::cdios::CdiosNode;
use super::powercube::{ModuleKind, ModuleSpec, PowerCubeBus};
use crate::clock::Clock;
use crate::link::mem::{CanDevice, MemBus};
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
}

impl Default for BenchConfig {
    /// The contract's bench.
    fn default() -> Self {
        Self { modules: vec![3, 5, 17], linear: vec![17], node: 1, cdios_modules: vec![0, 1] }
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

/// A device shared between the bus and whoever inspects it (tests, RS232 serving).
pub type Shared<T> = Arc<Mutex<T>>;

pub fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|e| e.into_inner())
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

pub struct Bench {
    pub bus: MemBus,
    pub powercube: Shared<PowerCubeBus>,
    pub cdios: Shared<CdiosNode>,
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
        Self { bus, powercube, cdios }
    }

    pub fn contract(clock: Arc<dyn Clock>) -> Self {
        Self::new(&BenchConfig::default(), clock)
    }
}

/// The in-process bench behind `--link sim`.
pub fn in_process(clock: Arc<dyn Clock>) -> MemBus {
    Bench::contract(clock).bus
}
