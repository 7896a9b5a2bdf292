//! The front end over the device face and the family registry: what the
//! generic commands check through the registry's ranges.

use crate::common;

/// `restore --to` takes an address of the file's family, checked against
/// the registry's id range before the link opens: nothing is sent.
#[test]
fn restore_to_an_address_outside_the_familys_range_is_refused_and_sends_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let text = |p: &std::path::Path| p.to_str().unwrap().to_string();
    for (family, save, to, said) in [
        ("powercube", ["-m", "3"], "0", "--to 0: a PowerCube address is a module id"),
        ("cdios", ["--node", "1"], "16", "--to 16: a Cdios address is a module id"),
    ] {
        let file = dir.path().join(format!("{family}.json"));
        let r = common::run(&["--link", "sim", "backup", "--family", family, save[0], save[1], "--out", &text(&file)]);
        assert_eq!(r.code, 0, "{family} backup: {}", r.stderr);
        // --to needs a file of one device.
        let mut doc: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&file).unwrap()).unwrap();
        doc["devices"].as_array_mut().unwrap().truncate(1);
        std::fs::write(&file, doc.to_string()).unwrap();
        let log = dir.path().join(format!("{family}.log"));
        let r = common::run(&["--link", "sim", "--log", &text(&log), "restore", &text(&file), "--to", to]);
        assert_eq!(r.code, 2, "{family}: {}", r.stderr);
        assert!(r.stderr.contains(said), "{family}: {}", r.stderr);
        let logged = std::fs::read_to_string(&log).unwrap_or_default();
        assert!(logged.trim().is_empty(), "{family}: nothing sent, logged:\n{logged}");
    }
}
