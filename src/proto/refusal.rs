//! A device's "no", as data: which family refused, with the code and the
//! manual's text, so that a JSON error can carry them and a message can
//! quote them. [`Refusal`]'s `Display` is the reason a human message gives.
//! Each family's refusal, its conversion from the family's error reply and
//! its words are in the family's folder (`proto::<family>::refusal`); this
//! is the one list of them.

use std::fmt;

use serde::Serialize;

use super::cdios::refusal::CdiosRefusal;
use super::pac::refusal::PacRefusal;
use super::powercube::refusal::PowerCubeRefusal;

/// What a device answered instead of doing what was asked.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
#[serde(tag = "family")]
pub enum Refusal {
    /// PA-CONTROL: QUIT != 0 in the acknowledge (manual 6.5).
    #[serde(rename = "pa-control")]
    PaControl(PacRefusal),
    /// Cdios: an error reply (code | 0x80) with its general error and status bits.
    #[serde(rename = "cdios")]
    Cdios(CdiosRefusal),
    /// PowerCube: the module's CubeState has error flags set.
    #[serde(rename = "powercube")]
    PowerCube(PowerCubeRefusal),
}

impl fmt::Display for Refusal {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::PaControl(p) => p.fmt(f),
            Self::Cdios(c) => c.fmt(f),
            Self::PowerCube(p) => p.fmt(f),
        }
    }
}
