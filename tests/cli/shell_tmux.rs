//! `axisctl shell` in a real terminal (tmux): completion from the parser's
//! tree, a command that runs, a failure that does not end the shell,
//! Ctrl-C at the prompt and during a motion, Ctrl-D, and the history kept
//! across two shells. Needs tmux, like tests/cli/dashboard_tmux.rs.

use crate::common;

use std::time::Duration;

use common::tmux::Tmux;

/// Waits for the `n`th prompt of the shell.
fn prompts(t: &Tmux, n: usize) -> String {
    t.wait_until(&format!("prompt {n}"), |s| s.matches(PROMPT).count() >= n)
}

/// A terminal whose shells keep their history under `state`.
fn terminal(state: &std::path::Path, name: &str) -> Tmux {
    Tmux::start(&format!("shell-{name}"), 100, 40, &[format!("XDG_STATE_HOME={}", state.display())])
}

/// As capture-pane shows it, without the trailing space.
const PROMPT: &str = "axisctl sim>";

#[test]
fn the_shell_completes_runs_survives_failures_and_keeps_its_history() {
    let state = tempfile::tempdir().unwrap();
    let t = terminal(state.path(), "main");
    t.wait_for("READY$");
    t.keys(&[&format!("{} --link sim shell", env!("CARGO_BIN_EXE_axisctl")), "Enter"]);
    prompts(&t, 1);
    // Completion from the clap tree: two tabs list what `pac-a` may become.
    t.keys(&["pac-a", "Tab", "Tab"]);
    let screen = t.wait_for("pac-axis-power");
    for want in ["pac-accel", "pac-auto-start", "pac-axes", "pac-axis-param"] {
        assert!(screen.contains(want), "{want} missing:\n{screen}");
    }
    // One candidate left: completed in the line, and the command runs.
    t.keys(&["xe", "Tab", "Enter"]);
    let screen = t.wait_for("300.0 AE");
    assert!(screen.contains("pac-axes"), "completed to pac-axes:\n{screen}");
    prompts(&t, 3);
    // Ctrl-C at the prompt clears the line; nothing runs.
    t.keys(&["get-config -m 17", "C-c"]);
    prompts(&t, 4);
    // A failure is said, and the shell goes on.
    t.keys(&["state -m 9", "Enter"]);
    t.wait_for("no answer from module 9");
    prompts(&t, 5);
    // Ctrl-C during a motion halts it; the shell goes on.
    t.keys(&["home -m 17 --wait", "Enter"]);
    std::thread::sleep(Duration::from_millis(400));
    t.keys(&["C-c"]);
    let screen = t.wait_for("halted: `halt -m 17`");
    assert!(screen.contains("stopped by SIGINT"), "{screen}");
    prompts(&t, 6);
    t.keys(&["get-param -m 17 CubeState", "Enter"]);
    t.wait_for("CubeState  0x27");
    prompts(&t, 7);
    assert!(!t.capture().contains("Config 0x"), "the cleared line never ran:\n{}", t.capture());
    // Ctrl-D ends the shell with 0.
    t.keys(&["C-d"]);
    t.wait_until("the return to bash", |s| s.matches("READY$").count() >= 2);
    t.keys(&["echo exit=$?", "Enter"]);
    t.wait_for("exit=0");
    let history = std::fs::read_to_string(state.path().join("axisctl/history")).expect("the history file");
    for line in ["pac-axes", "state -m 9", "home -m 17 --wait", "get-param -m 17 CubeState"] {
        assert!(history.lines().any(|l| l == line), "{line} not in the history:\n{history}");
    }
    assert!(!history.contains("get-config"), "a cleared line is no history:\n{history}");
    // A new shell starts from that history: Up brings the last line back.
    t.keys(&["clear", "Enter"]);
    t.keys(&[&format!("{} --link sim shell", env!("CARGO_BIN_EXE_axisctl")), "Enter"]);
    prompts(&t, 1);
    t.keys(&["Up"]);
    t.wait_for(&format!("{PROMPT} get-param -m 17 CubeState"));
    t.keys(&["C-c", "C-d"]);
}

// An emergency halt from another terminal sends SIGTERM to the process
// that holds the link; a shell waiting at its prompt must answer it too:
// it halts what its lines moved, gives the terminal back and exits.
#[test]
fn sigterm_at_the_prompt_halts_what_the_shell_moved_and_ends_it() {
    let state = tempfile::tempdir().unwrap();
    let t = terminal(state.path(), "term");
    t.wait_for("READY$");
    t.keys(&[&format!("{} --link sim shell", env!("CARGO_BIN_EXE_axisctl")), "Enter"]);
    prompts(&t, 1);
    t.keys(&["move-vel -m 3 0.1", "Enter"]);
    t.wait_for("acknowledged");
    prompts(&t, 2);
    unsafe { libc::kill(t.program_pid(), libc::SIGTERM) };
    let screen = t.wait_for("halted: `halt -m 3`");
    assert!(screen.contains("stopped by SIGTERM after line 1"), "{screen}");
    t.wait_until("the return to bash", |s| s.matches("READY$").count() >= 2);
    // Typed as DO''NE so that only the output says DONE.
    t.keys(&["s=$?; stty -a | tr ' ' '\\n' | grep -x -e icanon -e -icanon; echo exit=$s DO''NE", "Enter"]);
    let screen = t.wait_for("DONE");
    assert!(screen.contains("exit=143"), "{screen}");
    let lines: Vec<&str> = screen.lines().map(str::trim).collect();
    assert!(lines.contains(&"icanon") && !lines.contains(&"-icanon"), "the terminal is given back:\n{screen}");
}

// Ctrl-Z at the prompt (the line editor sends SIGTSTP to the process
// group) with a module still moving from a line without --wait: the shell
// halts it first, then stops; `fg` brings the prompt back, and the module
// is read halted and standing.
#[test]
fn ctrl_z_at_the_prompt_halts_what_the_shell_moved_then_stops_it() {
    let state = tempfile::tempdir().unwrap();
    let t = terminal(state.path(), "tstp");
    t.wait_for("READY$");
    t.keys(&[&format!("{} --link sim shell", env!("CARGO_BIN_EXE_axisctl")), "Enter"]);
    prompts(&t, 1);
    t.keys(&["move-vel -m 3 0.1", "Enter"]);
    t.wait_for("acknowledged");
    prompts(&t, 2);
    t.keys(&["C-z"]);
    let screen = t.wait_for("halted: `halt -m 3`");
    assert!(screen.contains("stopped by SIGTSTP after line 1"), "{screen}");
    let screen = t.wait_until("the job stopped, back in bash", |s| s.matches("READY$").count() >= 2);
    assert!(screen.contains("Stopped"), "bash reports the job stopped:\n{screen}");
    t.keys(&["fg", "Enter"]);
    t.keys(&["get-param -m 3 CubeState", "Enter"]);
    let screen = t.wait_until("the state read after fg", |s| s.contains("CubeState  0x"));
    let raw = screen.lines().find_map(|l| l.trim().strip_prefix("CubeState  0x")).unwrap();
    let raw = u32::from_str_radix(raw.split_whitespace().next().unwrap(), 16).unwrap();
    assert!(raw & 0x800 == 0 && raw & 0x4 != 0, "module 3 halted and standing: {raw:#x}\n{screen}");
    t.keys(&["C-d"]);
    t.wait_until("the return to bash", |s| s.matches("READY$").count() >= 3);
}

/// The state flags of module `m` on a served link, read by another process.
fn flags(link: &str, m: &str) -> Vec<String> {
    let r = common::run(&["--link", link, "--json", "state", "-m", m]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    r.json()["state"]["flags"].as_array().unwrap().iter().map(|f| f.as_str().unwrap().to_string()).collect()
}

// Issue 22, item 3: Ctrl-D or `exit` with a `move-vel` of the shell still
// running halts it and says so; `exit --keep-moving` leaves it moving and
// says that. The module's state is read from another process afterwards,
// on a served simulator.
#[test]
fn leaving_the_shell_halts_what_it_moved_unless_told_to_keep_it_moving() {
    let sim = common::Sim::start(&[], 3);
    let link = sim.link("powercube").to_string();
    let state = tempfile::tempdir().unwrap();
    for (end, said, moving) in [
        (&["C-d"][..], "Ctrl-D ends the shell; halted: `halt -m 3`", false),
        (&["exit", "Enter"][..], "exit ends the shell; halted: `halt -m 3`", false),
        (&["exit --keep-moving", "Enter"][..], "exit --keep-moving; not halted, may still move: `halt -m 3`", true),
    ] {
        let t = terminal(state.path(), "leave");
        t.wait_for("READY$");
        t.keys(&[&format!("{} --link {link} shell", env!("CARGO_BIN_EXE_axisctl")), "Enter"]);
        let prompt = format!("axisctl {link}>");
        t.wait_until("prompt 1", |s| s.contains(&prompt));
        t.keys(&["reset -m 3", "Enter"]);
        t.wait_until("prompt 2", |s| s.matches(&prompt).count() >= 2);
        t.keys(&["move-vel -m 3 0.1", "Enter"]);
        t.wait_for("FVEL_MODE 0.1 acknowledged");
        t.wait_until("prompt 3", |s| s.matches(&prompt).count() >= 3);
        t.keys(end);
        t.wait_until("the return to bash", |s| s.matches("READY$").count() >= 2);
        t.keys(&["echo exit=$? DO''NE", "Enter"]);
        let screen = t.wait_for("DONE");
        assert!(screen.contains(said), "{end:?}:\n{screen}");
        assert!(screen.contains("exit=0"), "{end:?}:\n{screen}");
        let f = flags(&link, "3");
        assert_eq!(f.contains(&"STATE_MOTION".to_string()), moving, "{end:?}: {f:?}");
        assert_eq!(f.contains(&"STATE_HALTED".to_string()), !moving, "{end:?}: {f:?}");
    }
}
