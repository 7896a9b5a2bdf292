//! The one device address at the binary's edge: a backup file keeps each
//! device's ids as written, so ids that are no device's are named as
//! written by `restore` and `diff` (docs/architecture.md, "One address").

use crate::common;

use common::run;
use serde_json::Value;

#[test]
fn a_backup_files_ids_that_are_no_devices_are_named_as_written() {
    let dir = tempfile::tempdir().unwrap();
    let saved = dir.path().join("cube.json");
    let r = run(&["--link", "sim", "backup", "--family", "powercube", "--out", saved.to_str().unwrap()]);
    assert_eq!(r.code, 0, "backup: {}", r.stderr);
    let mut doc: Value = serde_json::from_str(&std::fs::read_to_string(&saved).unwrap()).unwrap();
    let one = doc["devices"][0].clone();
    for (module, said) in [
        (Some(40), "powercube module 40: no PowerCube module id 1 to 31"),
        (None, "powercube: no PowerCube module id 1 to 31"),
    ] {
        let mut dev = one.clone();
        match module {
            Some(m) => dev["module"] = m.into(),
            None => _ = dev.as_object_mut().unwrap().remove("module"),
        }
        doc["devices"] = Value::Array(vec![dev]);
        let file = dir.path().join("bad.json");
        std::fs::write(&file, serde_json::to_string(&doc).unwrap()).unwrap();
        for cmd in [&["restore", file.to_str().unwrap(), "--dry-run"][..], &["diff", file.to_str().unwrap()]] {
            let r = run(&[&["--link", "sim"][..], cmd].concat());
            assert_eq!(r.code, 2, "{cmd:?}: {}", r.stderr);
            assert!(r.stderr.contains(said), "{cmd:?}: {}", r.stderr);
        }
    }
}
