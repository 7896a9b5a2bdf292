//! Shared helpers for the CLI tests: run the real binary, serve the bench.
#![allow(dead_code)]

pub mod bench;
pub mod heavy;
pub mod pool;
pub mod tmux;

use std::io::{BufRead, BufReader};
use std::process::{Child, Command, Output, Stdio};

/// The answer timeout every test run of the binary gets (`AXISCTL_TIMEOUT`).
pub const TIMEOUT_MS: &str = "400";

pub fn bin() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_axisctl"));
    // Tests check behaviour, not timing: a loaded CI machine must not turn a
    // slow simulator answer into a timeout. Tests that want the real default
    // remove the variable; a served simulator's runs may give more
    // ([`run_served`]).
    c.env_remove("AXISCTL_LINK").env_remove("AXISCTL_BENCH").env("NO_COLOR", "1").env("AXISCTL_TIMEOUT", TIMEOUT_MS);
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
    finished(bin().args(args).output().expect("run axisctl"))
}

/// `axisctl ARGS` against a simulator served by another process
/// ([`Sim`]): one that a loaded machine can starve for longer than
/// [`TIMEOUT_MS`] (a served PA-CONTROL was seen silent past 900 ms at three
/// test threads), so its answers are waited for 3 s.
pub fn run_served(args: &[&str]) -> Run {
    finished(bin().args(args).env("AXISCTL_TIMEOUT", "3000").output().expect("run axisctl"))
}

/// `axisctl ARGS` with `stdin` as its standard input.
pub fn run_with_stdin(args: &[&str], stdin: &str) -> Run {
    use std::io::Write;
    let mut child =
        bin().args(args).stdin(Stdio::piped()).stdout(Stdio::piped()).stderr(Stdio::piped()).spawn().unwrap();
    // Written beside the run: a batch reads its input as it runs, so a long
    // one would fill both pipes. A command that refuses its input stops
    // reading it, which closes the pipe: no error of the test.
    let (mut input, text) = (child.stdin.take().unwrap(), stdin.to_string());
    let writer = std::thread::spawn(move || drop(input.write_all(text.as_bytes())));
    let out = child.wait_with_output().unwrap();
    writer.join().unwrap();
    finished(out)
}

fn finished(Output { status, stdout, stderr }: Output) -> Run {
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
/// The schema describes each document exactly, so a valid document must
/// turn invalid when a key it does not know is added to any of its objects
/// (see [`with_an_unknown_key`]); each object that accepts one is reported.
pub fn schema_errors(v: &jsonschema::Validator, doc: &serde_json::Value) -> Option<String> {
    let errors: Vec<String> = v.iter_errors(doc).map(|e| format!("{} at {}", e, e.instance_path())).collect();
    if !errors.is_empty() {
        return Some(errors.join("\n"));
    }
    let open: Vec<String> = with_an_unknown_key(doc)
        .into_iter()
        .filter(|(_, d)| v.is_valid(d))
        .map(|(at, _)| format!("an unknown key added at {at:?} is accepted"))
        .collect();
    (!open.is_empty()).then(|| open.join("\n"))
}

/// The key [`with_an_unknown_key`] adds: no document has it.
pub const UNKNOWN_KEY: &str = "axisctl_unknown_key";

/// One copy of `doc` per object in it, at any depth, with [`UNKNOWN_KEY`]
/// added to that object, each with the object's JSON pointer ("" for the
/// top level). The added value is itself an object of that one key, so a
/// map keyed by names (`params`, `settings`, a recording's `values`) gets an
/// entry of no shape it allows.
pub fn with_an_unknown_key(doc: &serde_json::Value) -> Vec<(String, serde_json::Value)> {
    fn pointers(v: &serde_json::Value, at: String, out: &mut Vec<String>) {
        match v {
            serde_json::Value::Object(o) => {
                out.push(at.clone());
                for (k, x) in o {
                    pointers(x, format!("{at}/{}", k.replace('~', "~0").replace('/', "~1")), out);
                }
            }
            serde_json::Value::Array(a) => {
                for (i, x) in a.iter().enumerate() {
                    pointers(x, format!("{at}/{i}"), out);
                }
            }
            _ => {}
        }
    }
    let mut at = Vec::new();
    pointers(doc, String::new(), &mut at);
    at.into_iter()
        .map(|p| {
            let mut d = doc.clone();
            let o = d.pointer_mut(&p).and_then(serde_json::Value::as_object_mut).expect("an object");
            o.insert(UNKNOWN_KEY.into(), serde_json::json!({ UNKNOWN_KEY: true }));
            (p, d)
        })
        .collect()
}

/// How a child ended under a deadline: its exit code (-1 when a signal
/// ended it), that signal, and what it printed on the pipes it still had.
pub struct Ended {
    pub code: i32,
    pub signal: Option<i32>,
    pub stdout: String,
    pub stderr: String,
}

impl Ended {
    pub fn run(self) -> Run {
        Run { code: self.code, stdout: self.stdout, stderr: self.stderr }
    }
}

/// Waits at most `secs` for `child`, reading its stdout and stderr if they
/// are still piped; a child that hangs is killed and fails the test.
pub fn wait_bounded(mut child: Child, secs: u64, what: &[&str]) -> Ended {
    use std::io::Read;
    use std::os::unix::process::ExitStatusExt;
    use std::time::{Duration, Instant};
    fn drain(pipe: Option<impl Read + Send + 'static>) -> std::thread::JoinHandle<String> {
        std::thread::spawn(move || {
            let mut s = String::new();
            if let Some(mut p) = pipe {
                let _ = p.read_to_string(&mut s);
            }
            s
        })
    }
    let (out, err) = (drain(child.stdout.take()), drain(child.stderr.take()));
    let deadline = Instant::now() + Duration::from_secs(secs);
    let status = loop {
        if let Some(st) = child.try_wait().unwrap() {
            break st;
        }
        if Instant::now() > deadline {
            let _ = child.kill();
            let _ = child.wait();
            panic!("axisctl {what:?} hung for {secs} s");
        }
        std::thread::sleep(Duration::from_millis(5));
    };
    Ended {
        code: status.code().unwrap_or(-1),
        signal: status.signal(),
        stdout: out.join().unwrap(),
        stderr: err.join().unwrap(),
    }
}

/// A run that a signal interrupted: how it ended, and the time from the
/// signal to its exit.
pub struct Signalled {
    pub code: i32,
    pub killed_by: Option<i32>,
    pub stdout: String,
    pub stderr: String,
    pub reaction: std::time::Duration,
}

/// Runs axisctl with `--trace` and the real default timeout, and sends
/// `sig` `after` the first sent frame whose trace line contains `trigger`.
pub fn signal_when(args: &[&str], trigger: &str, after: std::time::Duration, sig: i32) -> Signalled {
    use std::time::{Duration, Instant};
    let mut all = vec!["--trace"];
    all.extend_from_slice(args);
    let mut child =
        bin().env_remove("AXISCTL_TIMEOUT").args(&all).stdout(Stdio::piped()).stderr(Stdio::piped()).spawn().unwrap();
    let (tx, rx) = std::sync::mpsc::channel();
    let err = child.stderr.take().unwrap();
    let trigger = trigger.to_string();
    let reader = std::thread::spawn(move || {
        let mut text = String::new();
        let mut told = false;
        for line in BufReader::new(err).lines().map_while(Result::ok) {
            if !told && line.starts_with("-> ") && line.contains(&trigger) {
                told = true;
                let _ = tx.send(());
            }
            text.push_str(&line);
            text.push('\n');
        }
        text
    });
    rx.recv_timeout(Duration::from_secs(10)).expect("the trigger line showed");
    std::thread::sleep(after);
    let t0 = Instant::now();
    unsafe {
        libc::kill(child.id() as i32, sig);
    }
    let ended = wait_bounded(child, 15, args);
    let reaction = t0.elapsed();
    Signalled {
        code: ended.code,
        killed_by: ended.signal,
        stdout: ended.stdout,
        stderr: reader.join().unwrap(),
        reaction,
    }
}

/// Every subcommand by path (`watchdog on`), read from the binary's own
/// help, with the example lines of its help that run on `--link sim`.
pub fn subcommands_and_sim_examples(path: &[String], out: &mut Vec<(String, Vec<Vec<String>>)>) {
    let help = run(&[path.iter().map(String::as_str).collect::<Vec<_>>(), vec!["--help"]].concat()).stdout;
    let section = |name: &str| -> Vec<String> {
        help.split(&format!("\n{name}:\n"))
            .nth(1)
            .map(|s| s.lines().take_while(|l| l.starts_with("  ") || l.is_empty()).map(str::to_string).collect())
            .unwrap_or_default()
    };
    // `axisctl --link sim ...` and `axisctl --link 'sim?pac=online' ...`:
    // the words after `axisctl`, the link's quotes taken off as the shell does.
    let examples = section("Examples")
        .iter()
        .map(|l| l.trim())
        .filter(|l| l.starts_with("axisctl --link sim ") || l.starts_with("axisctl --link 'sim?"))
        .map(|l| {
            let l = l.strip_prefix("axisctl ").unwrap_or(l).split('#').next().unwrap_or_default();
            // Redirections and pipes belong to the shell, not to axisctl.
            l.split_whitespace()
                .take_while(|w| !matches!(*w, ">" | "|" | "&&"))
                .map(|w| w.trim_matches('\'').to_string())
                .collect()
        })
        .collect();
    if !path.is_empty() {
        out.push((path.join(" "), examples));
    }
    for line in section("Commands") {
        let Some(name) = line.split_whitespace().next().filter(|n| *n != "help") else { continue };
        let mut sub = path.to_vec();
        sub.push(name.to_string());
        subcommands_and_sim_examples(&sub, out);
    }
}

/// Every `--help` page of the binary, the root's first, each with the
/// subcommand path that prints it.
pub fn help_pages() -> Vec<(String, String)> {
    fn walk(path: &mut Vec<String>, out: &mut Vec<(String, String)>) {
        let mut args: Vec<&str> = path.iter().map(String::as_str).collect();
        args.push("--help");
        let help = run(&args).stdout;
        let subcommands: Vec<String> = help
            .split("\nCommands:\n")
            .nth(1)
            .map(|s| {
                s.lines()
                    .take_while(|l| l.starts_with("  ") || l.is_empty())
                    .filter_map(|l| l.split_whitespace().next().filter(|n| *n != "help").map(str::to_string))
                    .collect()
            })
            .unwrap_or_default();
        out.push((path.join(" "), help));
        for name in subcommands {
            path.push(name);
            walk(path, out);
            path.pop();
        }
    }
    let mut out = Vec::new();
    walk(&mut Vec::new(), &mut out);
    out
}

/// What bash offers for `axisctl WORDS...` (the last word is the one under
/// the cursor; an empty one is the cursor after a space): the script
/// `completions bash` generates, sourced in a plain bash with `env` set,
/// its completion function called as bash calls it. One candidate per line.
pub fn bash_completion(words: &[&str], env: &[(&str, &str)]) -> Vec<String> {
    let dir = tempfile::tempdir().unwrap();
    let script = dir.path().join("axisctl.bash");
    let generated = run(&["completions", "bash"]);
    assert_eq!(generated.code, 0, "completions bash: {}", generated.stderr);
    std::fs::write(&script, generated.stdout).unwrap();
    let words = words.iter().map(|w| format!("'{w}'")).collect::<Vec<_>>().join(" ");
    let program = format!(
        r#"source '{}'
complete -p axisctl | grep -q -- '-F _clap_complete_axisctl' || {{ echo 'not registered' >&2; exit 3; }}
COMP_WORDS=(axisctl {words})
COMP_CWORD=$(( ${{#COMP_WORDS[@]}} - 1 ))
COMP_LINE="${{COMP_WORDS[*]}}"
COMP_POINT=${{#COMP_LINE}}
COMP_TYPE=9
_clap_complete_axisctl axisctl "${{COMP_WORDS[COMP_CWORD]}}" "${{COMP_WORDS[COMP_CWORD-1]}}"
printf '%s\n' "${{COMPREPLY[@]}}""#,
        script.display()
    );
    let bin_dir = std::path::Path::new(env!("CARGO_BIN_EXE_axisctl")).parent().unwrap().to_owned();
    let path = format!("{}:{}", bin_dir.display(), std::env::var("PATH").unwrap_or_default());
    let out = Command::new("bash")
        .args(["--norc", "--noprofile", "-c", &program])
        .env("PATH", path)
        .envs(env.iter().copied())
        .output()
        .unwrap_or_else(|e| panic!("bash is needed by this test ({e}); scripts/test.sh installs it"));
    assert!(out.status.success(), "bash: {}", String::from_utf8_lossy(&out.stderr));
    String::from_utf8_lossy(&out.stdout).lines().map(str::to_string).filter(|l| !l.is_empty()).collect()
}

/// The frames of a `--log` file (candump -l lines): when, and `ID#DATA`.
pub fn logged_frames(log: &std::path::Path) -> Vec<(f64, String)> {
    let text = std::fs::read_to_string(log).unwrap_or_default();
    text.lines()
        .filter_map(|l| {
            let (ts, rest) = l.strip_prefix('(')?.split_once(')')?;
            Some((ts.parse().ok()?, rest.split_whitespace().nth(1)?.to_string()))
        })
        .collect()
}

/// Module 3's ActPos answers in a `--log` file (`0A3#0A3C` + float): when, and where.
pub fn logged_positions_of_module_3(log: &std::path::Path) -> Vec<(f64, f32)> {
    logged_frames(log)
        .into_iter()
        .filter_map(|(t, f)| {
            let hex = f.strip_prefix("0A3#0A3C")?;
            let bytes: Vec<u8> =
                (0..4).map(|i| u8::from_str_radix(hex.get(2 * i..2 * i + 2)?, 16).ok()).collect::<Option<_>>()?;
            Some((t, f32::from_le_bytes(bytes.try_into().ok()?)))
        })
        .collect()
}

/// The longest step between consecutive times.
pub fn max_gap(times: &[f64]) -> f64 {
    times.windows(2).map(|w| w[1] - w[0]).fold(0.0, f64::max)
}
