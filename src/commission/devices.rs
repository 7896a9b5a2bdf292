//! The plan over the bench: each planned device resolved to its bench
//! address and handed to its family's checks (`commission::powercube`,
//! `::pac`, `::cdios`), which open their sessions through the device
//! registry's [`Sessions`] as they are first needed and keep them for the
//! run. This is the one place of the commissioning run that knows which
//! families there are: the command names none.

use std::fmt::Display;
use std::path::PathBuf;

use crate::backup::{self, Document};
use crate::bench::{Address, Bench, DeviceRef};
use crate::device::registry::Sessions;
use crate::family::Family;

use super::plan::{DevicePlan, Plan};
use super::{cdios, pac, powercube, DefaultPlanError, Run};

/// A device of the plan and where it is on the bench.
#[derive(Debug, Clone)]
pub struct Planned {
    pub address: Address,
    pub plan: DevicePlan,
}

/// Every device of the plan on the bench, each plan checked against what
/// its family can run; the error (for a usage error) before anything is
/// sent.
pub fn resolve(bench: &Bench, plan: &Plan) -> Result<Vec<Planned>, String> {
    let mut out = Vec::new();
    for d in &plan.device {
        let r: DeviceRef = d.address.parse().map_err(|e| format!("plan: {e}"))?;
        let address = bench.resolve(&r).map_err(|e| format!("plan: {e}"))?;
        match address.family() {
            Family::PowerCube => powercube::check_plan(d),
            Family::Pac => pac::check_plan(address, d),
            Family::Cdios => cdios::check_plan(d),
        }
        .map_err(|e| format!("plan: {}: {e}", d.address))?;
        out.push(Planned { address, plan: d.clone() });
    }
    Ok(out)
}

/// The motions the plan makes, as the confirmation lists them.
pub fn motions(devices: &[Planned]) -> Vec<String> {
    devices
        .iter()
        .flat_map(|d| match d.address.family() {
            Family::PowerCube => powercube::motions(&d.plan.address, &d.plan),
            Family::Pac => pac::motions(&d.plan.address, &d.plan),
            Family::Cdios => cdios::motions(&d.plan.address, &d.plan),
        })
        .collect()
}

/// The checks a plan asks of a device, in the order they run.
pub fn planned(d: &Planned) -> Vec<&'static str> {
    match d.address.family() {
        Family::PowerCube => powercube::planned(&d.plan),
        Family::Pac => pac::planned(d.address, &d.plan),
        Family::Cdios => cdios::planned(&d.plan),
    }
}

/// The default plan for every device of every family the bench carries:
/// each family's devices as its face finds them, in the registry's order.
/// With `only` (`commission -d`), the plan of those devices alone, and only
/// their families are asked (a link of another family is not opened), and
/// of those only the devices named are read; one not found is not in the
/// plan (a PowerCube module that does not answer: its timeout).
pub fn default_plan<S>(
    bench: &Bench,
    sessions: &mut S,
    run_link: &dyn Fn(Family) -> String,
    only: &[Address],
) -> Result<Plan, DefaultPlanError<S::Error>>
where
    S: Sessions,
    S::Error: Display,
{
    let mut device = Vec::new();
    let carried: Vec<Family> = bench.pairs().map(|(_, f)| f).collect();
    let asked = |f: Family| carried.contains(&f) && (only.is_empty() || only.iter().any(|a| a.family() == f));
    for family in crate::device::registry::FACES.into_iter().filter(|f| asked(*f)) {
        let link = run_link(family);
        let found = match family {
            Family::PowerCube => powercube::default_plan(sessions, &link, only),
            Family::Pac => pac::default_plan(sessions, &link, only),
            Family::Cdios => cdios::default_plan(sessions, &link, bench, only),
        };
        device.extend(found?);
    }
    Ok(Plan { device })
}

/// The sessions of the run, one per family, opened when first needed.
#[derive(Default)]
pub struct Open {
    cubes: powercube::Open,
    pac: pac::Open,
    cdios: cdios::Open,
}

/// Runs every device's checks in the plan's order. `Err`: a family's link
/// could not be opened (the run ends there, said in the report).
pub fn run_all<S>(
    sessions: &mut S,
    devices: &[Planned],
    files: &[(PathBuf, Document)],
    run: &mut Run,
) -> Result<(), String>
where
    S: Sessions,
    S::Error: Display,
{
    let mut open = Open::default();
    for d in devices {
        if run.interrupted {
            break;
        }
        let expected = expected_for(d, files);
        match d.address {
            Address::PowerCube { module } => open.cubes.run(sessions, module, &d.plan, expected, run)?,
            Address::Pac { axis } => open.pac.run(sessions, axis, &d.plan, expected, run)?,
            Address::Cdios { node, module } => open.cdios.run(sessions, node, module, &d.plan, expected, run)?,
        }
        // A check the stop cut short (a failed output as well as a
        // signal) failed of the stop, not of the device.
        run.interrupted |= (run.stop)();
    }
    Ok(())
}

/// The planned device's entry in the plan's backup file, if it names one
/// (`files`: each file the plan names, read once, by its path).
fn expected_for<'f>(d: &Planned, files: &'f [(PathBuf, Document)]) -> Option<&'f backup::Device> {
    let name = d.plan.settings.as_ref()?.backup.as_ref()?;
    let (_, doc) = files.iter().find(|(p, _)| p.ends_with(name))?;
    let want = backup_address(d.address);
    doc.devices.iter().find(|dev| dev.address() == want)
}

/// The bench address in a backup's terms.
pub fn backup_address(a: Address) -> backup::Address {
    let (family, module, axis, node) = match a {
        Address::PowerCube { module } => (Family::PowerCube, Some(module), None, None),
        Address::Pac { axis } => (Family::Pac, None, axis, None),
        Address::Cdios { node, module } => (Family::Cdios, Some(module), None, Some(node)),
    };
    backup::Address { family, module, axis, node }
}
