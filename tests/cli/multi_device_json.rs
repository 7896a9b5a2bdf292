//! Reads of several devices: a list or `all` gives `{"devices": [...]}`,
//! one object per device in id order, each with its envelope; one id gives
//! one object.

use crate::common;

use common::run;
use serde_json::Value;

fn devices(args: &[&str], key: &str) -> (Vec<u64>, Value) {
    let r = run(args);
    assert_eq!(r.code, 0, "{args:?}: {}", r.stderr);
    let doc = r.json();
    let ids = doc["devices"]
        .as_array()
        .unwrap_or_else(|| panic!("{args:?}: no devices in {doc}"))
        .iter()
        .map(|d| d[key].as_u64().unwrap_or_else(|| panic!("{key} in {d}")))
        .collect();
    (ids, doc)
}

#[test]
fn powercube_reads_take_a_list_or_all() {
    let (ids, doc) = devices(&["--link", "sim", "--json", "get-param", "-m", "17,3,5", "ActPos"], "module");
    assert_eq!(ids, [3, 5, 17]);
    let units: Vec<&str> =
        doc["devices"].as_array().unwrap().iter().filter_map(|d| d["params"]["ActPos"]["unit"].as_str()).collect();
    assert_eq!(units, ["rad", "rad", "m"], "17 is linear");
    assert_eq!(devices(&["--link", "sim", "--json", "state", "-m", "all"], "module").0, [3, 5, 17]);
    let (ids, doc) = devices(&["--link", "sim", "--json", "info", "-m", "3,17"], "module");
    assert_eq!(ids, [3, 17]);
    assert_eq!(doc["devices"][1]["params"]["MaxPos"]["unit"], "m", "{doc}");
}

#[test]
fn the_shape_follows_what_was_typed() {
    assert_eq!(devices(&["--link", "sim", "--json", "state", "-m", "17,"], "module").0, [17]);
    let one = run(&["--link", "sim", "--json", "state", "-m", "17"]).json();
    assert_eq!((one["module"].as_u64(), one.get("devices")), (Some(17), None));
}

#[test]
fn a_listed_module_that_does_not_answer_fails_the_read() {
    let r = run(&["--link", "sim", "--json", "--timeout", "20", "get-param", "-m", "3,9", "ActPos"]);
    assert_eq!(r.code, 4, "{}", r.stderr);
    assert!(r.stdout.is_empty(), "{}", r.stdout);
    let e: Value = serde_json::from_str(r.stderr.trim()).unwrap();
    assert_eq!(e["error"]["module"], 9, "{e}");
}

#[test]
fn human_output_names_each_module() {
    let r = run(&["--link", "sim", "get-param", "-m", "3,5", "ActPos"]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    assert!(r.stdout.contains("module 3:") && r.stdout.contains("module 5:"), "{}", r.stdout);
}

#[test]
fn pac_axis_takes_a_list_or_all() {
    assert_eq!(devices(&["--link", "sim", "--json", "pac-axis", "all"], "axis").0, [1, 2, 3]);
    let (ids, doc) = devices(&["--link", "sim", "--json", "pac-axis", "3,1"], "axis");
    assert_eq!(ids, [1, 3]);
    assert!(doc["devices"].as_array().unwrap().iter().all(|d| d["family"] == "pac"), "{doc}");
}

#[test]
fn cdios_reads_take_a_list_or_all() {
    assert_eq!(devices(&["--link", "sim", "--json", "cdios-status", "-m", "all"], "module").0, [0, 1]);
    let (ids, doc) = devices(&["--link", "sim", "--json", "cdios-position", "-m", "0,1", "--all"], "module");
    assert_eq!(ids, [0, 1]);
    assert!(
        doc["devices"]
            .as_array()
            .unwrap()
            .iter()
            .all(|d| d["node"] == 1 && d["setpoint"]["value"].is_i64() && d["setpoint"]["unit"] == "counts"),
        "{doc}"
    );
}

// The modules home together and are waited for one after the other: each
// one's elapsed time counts from the broadcast, so none reports 0.
#[test]
fn home_all_wait_times_every_module_from_the_broadcast() {
    let (ids, doc) = devices(&["--link", "sim", "--json", "home", "--all", "--wait"], "module");
    assert_eq!(ids, [3, 5, 17]);
    let ms: Vec<u64> = doc["devices"].as_array().unwrap().iter().map(|d| d["elapsed_ms"].as_u64().unwrap()).collect();
    assert!(ms.iter().all(|&t| t > 0) && ms.windows(2).all(|w| w[1] >= w[0]), "{ms:?}");
}

// `--node` takes a list as `-m` does: each node's modules are read on one
// link, in node order. The bench has node 1 only, so node 2 is asked after
// node 1 answered, and its silence is the command's error.
#[test]
fn cdios_reads_take_a_list_of_nodes() {
    let (ids, doc) = devices(&["--link", "sim", "--json", "cdios-status", "--node", "1,", "-m", "0"], "node");
    assert_eq!(ids, [1], "a list of one node is still a list: {doc}");
    let r =
        run(&["--link", "sim", "--json", "--trace", "--retries", "0", "cdios-position", "--node", "2,1", "-m", "0"]);
    assert_eq!(r.code, 4, "{}", r.stderr);
    let sent: Vec<&str> = r.stderr.lines().filter(|l| l.starts_with("-> ")).collect();
    let node1_read = sent.iter().position(|l| l.ends_with("read_position current to node 1 module 0"));
    let node2_first = sent.iter().position(|l| l.contains("node 2"));
    assert!(node1_read.is_some() && node2_first > node1_read, "node 1 read, then node 2 asked: {sent:?}");
    let error: Value = serde_json::from_str(r.stderr.lines().last().unwrap()).unwrap();
    assert_eq!((&error["error"]["node"], &error["error"]["module"]), (&2.into(), &0.into()), "{error}");
    let all = run(&["--link", "sim", "--json", "cdios-status", "--node", "all", "-m", "0"]);
    assert_eq!(all.code, 2, "{}", all.stderr);
}
