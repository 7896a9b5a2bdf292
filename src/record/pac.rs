//! PA-CONTROL axes: the half-duplex line takes one request at a time, so a
//! sample is one read after the other, as fast as the line allows.

use super::{Channel, HaltMotion, RecordError, Sampler};
use crate::address::Address;
use crate::device::face::{Face, FaceError};
use crate::device::pac::{Controller, Error};

/// An axis value that can be recorded, with the command that reads it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PacValue {
    /// 190C actual position.
    Position,
    /// 190D actual speed.
    Speed,
    /// 1910 axis status (0 in position, 1 moving, 2 stopped, 4 fault, 8 measuring).
    Status,
}

impl PacValue {
    pub const ALL: [Self; 3] = [Self::Position, Self::Speed, Self::Status];

    pub fn name(self) -> &'static str {
        match self {
            Self::Position => "position",
            Self::Speed => "speed",
            Self::Status => "status",
        }
    }

    pub fn parse(text: &str) -> Option<Self> {
        super::by_name(&Self::ALL, Self::name, text)
    }

    fn unit(self) -> &'static str {
        match self {
            Self::Position => "AE",
            Self::Speed => "AE/s",
            Self::Status => "",
        }
    }

    fn code(self) -> u16 {
        match self {
            Self::Position => 0x190C,
            Self::Speed => 0x190D,
            Self::Status => 0x1910,
        }
    }
}

pub struct PacSampler {
    ctl: Controller,
    reads: Vec<(u8, PacValue)>,
    channels: Vec<Channel>,
}

impl PacSampler {
    pub fn new(ctl: Controller, axes: &[u8], values: &[PacValue]) -> Self {
        let reads: Vec<(u8, PacValue)> = axes.iter().flat_map(|a| values.iter().map(move |v| (*a, *v))).collect();
        let channels = reads
            .iter()
            .map(|(a, v)| Channel {
                address: Address::Pac { axis: Some(*a) },
                name: v.name().into(),
                unit: v.unit().into(),
            })
            .collect();
        Self { ctl, reads, channels }
    }

    pub fn controller(&mut self) -> &mut Controller {
        &mut self.ctl
    }
}

impl Sampler for PacSampler {
    fn channels(&self) -> &[Channel] {
        &self.channels
    }

    fn sample(&mut self) -> Result<Vec<f64>, RecordError> {
        let mut out = Vec::with_capacity(self.reads.len());
        for (axis, v) in &self.reads {
            out.push(self.ctl.read_f64(v.code(), i64::from(*axis))?);
        }
        Ok(out)
    }
}

impl From<Error> for RecordError {
    fn from(e: Error) -> Self {
        FaceError::from(e).into()
    }
}

impl HaltMotion for PacSampler {
    fn face(&mut self) -> &mut dyn Face {
        self.controller()
    }
}
