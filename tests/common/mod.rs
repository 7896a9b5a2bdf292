//! Shared helpers for the CLI tests: run the real binary, serve the bench.
#![allow(dead_code)]

use std::io::{BufRead, BufReader};
use std::process::{Child, Command, Output, Stdio};

pub fn bin() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_axisctl"));
    // Tests check behaviour, not timing: a loaded CI machine must not turn a
    // slow simulator answer into a timeout. Tests that want the real default
    // remove the variable.
    c.env_remove("AXISCTL_LINK").env("NO_COLOR", "1").env("AXISCTL_TIMEOUT", "400");
    c
}

pub struct Run {
    pub code: i32,
    pub stdout: String,
    pub stderr: String,
}

impl Run {
    pub fn json(&self) -> serde_json::Value {
        serde_json::from_str(&self.stdout).unwrap_or_else(|e| panic!("stdout is not JSON ({e}): {:?}", self.stdout))
    }
}

pub fn run(args: &[&str]) -> Run {
    let Output { status, stdout, stderr } = bin().args(args).output().expect("run axisctl");
    Run {
        code: status.code().unwrap_or(-1),
        stdout: String::from_utf8_lossy(&stdout).into(),
        stderr: String::from_utf8_lossy(&stderr).into(),
    }
}

/// `axisctl sim` in the background; killed on drop.
pub struct Sim {
    child: Child,
    pub links: Vec<(String, String)>,
}

impl Sim {
    pub fn start(args: &[&str], expect_links: usize) -> Self {
        let mut child = bin()
            .arg("sim")
            .args(args)
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit())
            .spawn()
            .expect("start axisctl sim");
        let mut lines = BufReader::new(child.stdout.take().unwrap()).lines();
        let mut links = Vec::new();
        while links.len() < expect_links {
            let line = lines.next().expect("sim printed a line").expect("read sim line");
            let v: serde_json::Value = serde_json::from_str(&line).expect("sim prints JSON lines");
            links.push((v["family"].as_str().unwrap().to_string(), v["link"].as_str().unwrap().to_string()));
        }
        Self { child, links }
    }

    /// Kills the simulator at once, as pulling the adapter's plug would:
    /// its ptys close under whoever has them open.
    pub fn unplug(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }

    pub fn link(&self, family: &str) -> &str {
        &self.links.iter().find(|(f, _)| f == family).expect("family served").1
    }
}

impl Drop for Sim {
    fn drop(&mut self) {
        unsafe {
            libc::kill(self.child.id() as i32, libc::SIGTERM);
        }
        let _ = self.child.wait();
    }
}

/// A validator for one definition of the published schema
/// (schema/axisctl.schema.json), e.g. `document`, `error_document`, `stream_line`.
pub fn schema(def: &str) -> jsonschema::Validator {
    let text = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/schema/axisctl.schema.json")).unwrap();
    let mut root: serde_json::Value = serde_json::from_str(&text).expect("the schema is JSON");
    root.as_object_mut().unwrap().remove("anyOf");
    root["$ref"] = serde_json::Value::from(format!("#/$defs/{def}"));
    jsonschema::validator_for(&root).unwrap_or_else(|e| panic!("schema: {e}"))
}

/// Every way `doc` breaks the definition, one per line; `None` when valid.
pub fn schema_errors(v: &jsonschema::Validator, doc: &serde_json::Value) -> Option<String> {
    let errors: Vec<String> = v.iter_errors(doc).map(|e| format!("{} at {}", e, e.instance_path())).collect();
    (!errors.is_empty()).then(|| errors.join("\n"))
}
