//! Cdios 6168 modules: the chosen reads of each module in one pipelined
//! burst (the node answers them in order), as the dashboard polls it.

use super::{Channel, HaltMotion, RecordError, Sampler};
use crate::address::Address;
use crate::device::cdios::{Error, Node};
use crate::device::face::{Face, FaceError};
use crate::proto::cdios::table;
use crate::proto::cdios::{Address as CdiosAddress, Command, ModuleId, PositionSource, StatusSelector};

/// A module value that can be recorded.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CdiosValue {
    /// Current motor position (counts: the manual gives no unit).
    Position,
    /// Setpoint position (counts).
    Setpoint,
    /// Motor speed, rpm.
    Speed,
    /// RPM error.
    RpmError,
}

impl CdiosValue {
    pub const ALL: [Self; 4] = [Self::Position, Self::Setpoint, Self::Speed, Self::RpmError];

    pub fn name(self) -> &'static str {
        match self {
            Self::Position => "position",
            Self::Setpoint => "setpoint",
            Self::Speed => "speed",
            Self::RpmError => "rpm-error",
        }
    }

    pub fn parse(text: &str) -> Option<Self> {
        super::by_name(&Self::ALL, Self::name, text)
    }

    fn unit(self) -> &'static str {
        match self {
            Self::Position | Self::Setpoint => table::POSITION_UNIT,
            Self::Speed | Self::RpmError => table::SPEED_UNIT,
        }
    }

    fn command(self) -> Command {
        match self {
            Self::Position => Command::ReadPosition(PositionSource::Current),
            Self::Setpoint => Command::ReadPosition(PositionSource::Setpoint),
            Self::Speed | Self::RpmError => Command::ReadStatus(StatusSelector::SpeedError),
        }
    }

    fn field(self) -> &'static str {
        match self {
            Self::Position | Self::Setpoint => "position",
            Self::Speed => "motor_speed",
            Self::RpmError => "rpm_error",
        }
    }
}

pub struct CdiosSampler {
    node: Node,
    modules: Vec<ModuleId>,
    values: Vec<CdiosValue>,
    /// The reads of one module: speed and RPM error share one.
    cmds: Vec<Command>,
    channels: Vec<Channel>,
}

impl CdiosSampler {
    /// Starts the node first (NMT and its settle time, once per session), so
    /// that the first sample's time stamp is not 100 ms early.
    pub fn new(mut node: Node, modules: &[ModuleId], values: &[CdiosValue]) -> Result<Self, RecordError> {
        let id = node.id();
        node.session().start_node(id).map_err(Error::from)?;
        let mut cmds: Vec<Command> = Vec::new();
        for v in values {
            if !cmds.contains(&v.command()) {
                cmds.push(v.command());
            }
        }
        let n = node.id().get();
        let channels = modules
            .iter()
            .flat_map(|m| {
                values.iter().map(move |v| Channel {
                    address: Address::Cdios { node: n, module: m.get() },
                    name: v.name().into(),
                    unit: v.unit().into(),
                })
            })
            .collect();
        Ok(Self { node, modules: modules.to_vec(), values: values.to_vec(), cmds, channels })
    }

    pub fn node(&mut self) -> &mut Node {
        &mut self.node
    }
}

impl Sampler for CdiosSampler {
    fn channels(&self) -> &[Channel] {
        &self.channels
    }

    fn sample(&mut self) -> Result<Vec<f64>, RecordError> {
        let id = self.node.id();
        let mut out = Vec::with_capacity(self.channels.len());
        for m in &self.modules {
            let replies =
                self.node.session().read_many(id, CdiosAddress::Module(*m), &self.cmds).map_err(Error::from)?;
            for v in &self.values {
                let i = self.cmds.iter().position(|c| *c == v.command()).expect("every value has its read");
                out.push(replies[i].get(v.field()).map_or(f64::NAN, |x| x as f64));
            }
        }
        Ok(out)
    }
}

impl From<Error> for RecordError {
    fn from(e: Error) -> Self {
        FaceError::from(e).into()
    }
}

impl HaltMotion for CdiosSampler {
    fn face(&mut self) -> &mut dyn Face {
        self.node()
    }
}
