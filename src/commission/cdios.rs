//! The checks of a Cdios module. Not commissioned yet: a plan naming one
//! is refused before anything is sent.

use std::fmt::Display;

use super::plan::DevicePlan;
use super::Run;
use crate::backup::Device;
use crate::bench::Bench;
use crate::device::registry::Sessions;

pub fn check_plan(_plan: &DevicePlan) -> Result<(), String> {
    Err("a Cdios device: commission runs PowerCube modules only so far".into())
}

pub fn motions(_at: &str, _plan: &DevicePlan) -> Vec<String> {
    Vec::new()
}

pub fn planned(_plan: &DevicePlan) -> Vec<&'static str> {
    Vec::new()
}

pub fn default_plan<S: Sessions>(
    _sessions: &mut S,
    _link: &str,
    _bench: &Bench,
) -> Result<Vec<DevicePlan>, super::DefaultPlanError<S::Error>> {
    Ok(Vec::new())
}

#[derive(Default)]
pub struct Open;

impl Open {
    pub fn run<S>(
        &mut self,
        _: &mut S,
        _: u8,
        _: u8,
        _: &DevicePlan,
        _: Option<&Device>,
        _: &mut Run,
    ) -> Result<(), String>
    where
        S: Sessions,
        S::Error: Display,
    {
        Err("a Cdios device cannot be commissioned yet".into())
    }
}
