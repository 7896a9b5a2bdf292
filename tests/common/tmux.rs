//! A real terminal for the tests of the dashboard and the shell: tmux
//! running a plain bash whose prompt is `READY$ `, driven with keys and read
//! back with capture-pane. Needs tmux (scripts/test.sh installs it); without
//! it the test fails and says so.

use std::process::Command;
use std::time::{Duration, Instant};

pub struct Tmux {
    session: String,
}

impl Tmux {
    /// A `w` x `h` terminal for the test `name`, with `env` (`KEY=value`)
    /// set for the shell besides PATH, TERM and PS1.
    pub fn start(name: &str, w: u16, h: u16, env: &[String]) -> Self {
        let found = Command::new("tmux").arg("-V").output().map(|o| o.status.success()).unwrap_or(false);
        assert!(found, "tmux is not installed: the {name} test needs it (apt-get install tmux)");
        // Tests run in parallel: each needs a session of its own.
        static NEXT: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
        let n = NEXT.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        let session = format!("axisctl-{name}-{}-{n}", std::process::id());
        // Sessions started at once race to start the tmux server, and a
        // loser fails ("server exited unexpectedly"): one start at a time,
        // and a failed start is tried again.
        static STARTING: std::sync::Mutex<()> = std::sync::Mutex::new(());
        let _one = STARTING.lock().unwrap_or_else(|e| e.into_inner());
        let mut failures = Vec::new();
        for _ in 0..5 {
            let out = Command::new("tmux")
                .args(["new-session", "-d", "-s", &session, "-x", &w.to_string(), "-y", &h.to_string()])
                .args(["env", "-i", "PATH=/usr/bin:/bin", "TERM=screen", "PS1=READY$ "])
                .args(env)
                .args(["bash", "--norc", "--noprofile"])
                .output()
                .expect("run tmux");
            if out.status.success() {
                return Self { session };
            }
            failures.push(String::from_utf8_lossy(&out.stderr).trim().to_string());
            std::thread::sleep(Duration::from_millis(200));
        }
        panic!("tmux new-session failed 5 times: {failures:?}")
    }

    pub fn keys(&self, keys: &[&str]) {
        let ok = Command::new("tmux").args(["send-keys", "-t", &self.session]).args(keys).status().unwrap().success();
        assert!(ok, "tmux send-keys {keys:?}");
    }

    pub fn capture(&self) -> String {
        let out = Command::new("tmux").args(["capture-pane", "-p", "-t", &self.session]).output().unwrap();
        String::from_utf8_lossy(&out.stdout).into()
    }

    /// tmux's display-message of `format` (`#{pane_pid}`, `#{cursor_flag}`...).
    pub fn display(&self, format: &str) -> String {
        let out = Command::new("tmux").args(["display-message", "-p", "-t", &self.session, format]).output().unwrap();
        String::from_utf8_lossy(&out.stdout).trim().into()
    }

    /// The pid of the program the pane's bash runs (its first child).
    pub fn program_pid(&self) -> i32 {
        let shell = self.display("#{pane_pid}");
        let deadline = Instant::now() + Duration::from_secs(10);
        loop {
            let children = std::fs::read_to_string(format!("/proc/{shell}/task/{shell}/children")).unwrap_or_default();
            if let Some(pid) = children.split_whitespace().next() {
                return pid.parse().unwrap();
            }
            assert!(Instant::now() < deadline, "no program under the shell {shell}");
            std::thread::sleep(Duration::from_millis(50));
        }
    }

    /// Waits up to 15 s until `test` holds for the pane; fails showing the pane.
    pub fn wait_until(&self, what: &str, test: impl Fn(&str) -> bool) -> String {
        let deadline = Instant::now() + Duration::from_secs(15);
        loop {
            let screen = self.capture();
            if test(&screen) {
                return screen;
            }
            assert!(Instant::now() < deadline, "{what} never happened; the pane shows:\n{screen}");
            std::thread::sleep(Duration::from_millis(50));
        }
    }

    /// Waits until the pane shows `text`.
    pub fn wait_for(&self, text: &str) -> String {
        self.wait_until(&format!("{text:?}"), |s| s.contains(text))
    }
}

impl Drop for Tmux {
    fn drop(&mut self) {
        let _ = Command::new("tmux").args(["kill-session", "-t", &self.session]).status();
    }
}
