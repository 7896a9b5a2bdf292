//! The simulated bench: the devices of `cli-contract.md` on one in-memory
//! CAN bus (PowerCube modules 3, 5 and 17, 17 linear), and a PA-CONTROL with
//! 3 axes on its own serial line, shared by the in-process `--link sim` and
//! by `axisctl sim`'s served links.

use std::sync::{Arc, Mutex, MutexGuard};
use std::time::Instant;

use super::pac::PacController;
use super::powercube::{ModuleKind, ModuleSpec, PowerCubeBus};
use crate::clock::Clock;
use crate::link::mem::{CanDevice, MemBus, MemByteLink};
use crate::proto::powercube::ModuleId;
use crate::proto::CanFrame;

/// What the bench holds.
#[derive(Debug, Clone)]
pub struct BenchConfig {
    pub modules: Vec<u8>,
    pub linear: Vec<u8>,
    /// PA-CONTROL axes (1..=16).
    pub axes: u8,
}

impl Default for BenchConfig {
    /// The contract's bench.
    fn default() -> Self {
        Self { modules: vec![3, 5, 17], linear: vec![17], axes: 3 }
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

pub struct Bench {
    pub bus: MemBus,
    pub powercube: Shared<PowerCubeBus>,
    /// The PA-CONTROL, reached over [`Bench::pac_link`] or a served pty.
    pub pac: Shared<PacController>,
}

impl Bench {
    pub fn new(cfg: &BenchConfig, clock: Arc<dyn Clock>) -> Self {
        let now = clock.now();
        let bus = MemBus::new(clock);
        let powercube = Arc::new(Mutex::new(PowerCubeBus::new(cfg.module_specs(), now)));
        bus.attach(Box::new(SharedPowerCube(Arc::clone(&powercube))));
        let pac = Arc::new(Mutex::new(PacController::new(cfg.axes, now)));
        Self { bus, powercube, pac }
    }

    /// A serial line to the PA-CONTROL (the in-process `--link sim`); every
    /// link opened here talks to the same controller.
    pub fn pac_link(&self, clock: Arc<dyn Clock>) -> MemByteLink {
        MemByteLink::new(Box::new(Arc::clone(&self.pac)), clock)
    }

    pub fn contract(clock: Arc<dyn Clock>) -> Self {
        Self::new(&BenchConfig::default(), clock)
    }
}

/// The in-process bench behind `--link sim`.
pub fn in_process(clock: Arc<dyn Clock>) -> MemBus {
    Bench::contract(clock).bus
}
