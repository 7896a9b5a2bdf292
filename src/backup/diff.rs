//! The diff of two backups (or a backup and the live bench read into the
//! same shape): per device, the identity keys and restorable settings whose
//! values differ.

use serde::Serialize;

use super::{Address, Device, Document};

/// One value that differs; `None` where one side has no such value (or no
/// such device).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Difference {
    pub name: String,
    pub unit: String,
    pub left: Option<serde_json::Value>,
    pub right: Option<serde_json::Value>,
}

/// The differences of one device, in the left document's order (devices
/// only the right one has come last).
#[derive(Debug, Clone, PartialEq)]
pub struct DeviceDiff {
    pub address: Address,
    pub link: String,
    pub differences: Vec<Difference>,
}

/// Whether two stored values mean the same: numbers within a float's
/// precision (both sides come from the same f32, but one may have been
/// typed by hand), anything else exactly.
pub fn same_value(a: &serde_json::Value, b: &serde_json::Value) -> bool {
    match (a.as_f64(), b.as_f64()) {
        (Some(x), Some(y)) => x == y || (x - y).abs() <= 1e-6 * x.abs().max(y.abs()),
        _ => a == b,
    }
}

/// Every device of both documents; each compared on the identity keys
/// either side holds and on the settings either side restores.
///
/// A device of the left is paired with the right's device at the same
/// address on the same link, else with the first one not yet paired at that
/// address (the ports of a served simulator, or the adapter's path, change
/// from run to run): two links of a bench may each have a module 3.
pub fn diff(left: &Document, right: &Document) -> Vec<DeviceDiff> {
    let mut paired = vec![false; right.devices.len()];
    let mut out = Vec::new();
    for l in &left.devices {
        let free = |i: &usize| !paired[*i] && right.devices[*i].address() == l.address();
        let all = 0..right.devices.len();
        let r = all.clone().filter(free).find(|i| right.devices[*i].link == l.link).or_else(|| all.clone().find(free));
        if let Some(i) = r {
            paired[i] = true;
        }
        let r = r.map(|i| &right.devices[i]);
        out.push(DeviceDiff { address: l.address(), link: l.link.clone(), differences: device_diff(Some(l), r) });
    }
    for (r, _) in right.devices.iter().zip(&paired).filter(|(_, p)| !**p) {
        out.push(DeviceDiff { address: r.address(), link: r.link.clone(), differences: device_diff(None, Some(r)) });
    }
    out
}

fn device_diff(left: Option<&Device>, right: Option<&Device>) -> Vec<Difference> {
    let mut out = Vec::new();
    let sides = [left, right];
    let mut keys: Vec<&String> = sides.iter().flatten().flat_map(|d| d.identity.keys()).collect();
    keys.sort();
    keys.dedup();
    for k in keys {
        let [l, r] = sides.map(|d| d.and_then(|d| d.identity.get(k)).cloned());
        if !matches!((&l, &r), (Some(a), Some(b)) if same_value(a, b)) {
            out.push(Difference { name: format!("identity.{k}"), unit: String::new(), left: l, right: r });
        }
    }
    let mut names: Vec<&String> =
        sides.iter().flatten().flat_map(|d| d.settings.iter().filter(|(_, s)| s.restore).map(|(n, _)| n)).collect();
    names.sort();
    names.dedup();
    for n in names {
        let [l, r] = sides.map(|d| d.and_then(|d| d.settings.get(n)));
        if matches!((l, r), (Some(a), Some(b)) if same_value(&a.value, &b.value)) {
            continue;
        }
        let unit = l.or(r).map(|s| s.unit.clone()).unwrap_or_default();
        out.push(Difference {
            name: n.clone(),
            unit,
            left: l.map(|s| s.value.clone()),
            right: r.map(|s| s.value.clone()),
        });
    }
    out
}
