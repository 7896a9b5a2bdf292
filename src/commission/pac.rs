//! The checks of the PA-CONTROL. Not commissioned yet: a plan naming it is
//! refused before anything is sent.

use std::fmt::Display;

use super::plan::DevicePlan;
use super::Run;
use crate::backup::Device;
use crate::bench::Address;
use crate::device::registry::Sessions;

pub fn check_plan(_at: Address, _plan: &DevicePlan) -> Result<(), String> {
    Err("a PA-CONTROL device: commission runs PowerCube modules only so far".into())
}

pub fn motions(_at: &str, _plan: &DevicePlan) -> Vec<String> {
    Vec::new()
}

pub fn planned(_at: Address, _plan: &DevicePlan) -> Vec<&'static str> {
    Vec::new()
}

pub fn default_plan<S: Sessions>(
    _sessions: &mut S,
    _link: &str,
) -> Result<Vec<DevicePlan>, super::DefaultPlanError<S::Error>> {
    Ok(Vec::new())
}

#[derive(Default)]
pub struct Open;

impl Open {
    pub fn run<S>(
        &mut self,
        _: &mut S,
        _: Option<u8>,
        _: &DevicePlan,
        _: Option<&Device>,
        _: &mut Run,
    ) -> Result<(), String>
    where
        S: Sessions,
        S::Error: Display,
    {
        Err("a PA-CONTROL device cannot be commissioned yet".into())
    }

    pub fn finish(&mut self, _run: &mut Run) {}
}
