//! `axisctl dashboard`: a ratatui screen over every device on the links.
//!
//! - [`app`]: the state, pure: events in, requests for the workers out.
//! - [`event`]: the one [`event::Event`] enum (keys, worker reports, ticks).
//! - [`ui`]: drawing, a pure function of the state.
//! - [`worker`]: one thread per link, polling its device sources.
//! - [`source`] and the family modules: what a device source is and does.
//! - [`keys`]: the key bindings, declared once.
//!
//! The terminal is restored by a guard on every way out of [`run`] and by a
//! panic hook when the UI thread panics. SIGTERM and SIGHUP (terminal
//! closed, SSH dropped) halt what the dashboard moved, restore the terminal
//! and end [`run`] with [`Terminated`]. So does a panic on any thread (an
//! unwind guard on the UI thread, the worker's own guard, the panic hook's
//! record for any other thread) and a draw that fails (the terminal cannot
//! be written): they end [`run`] with [`Stopped`], or go on panicking.

pub mod app;
pub mod cdios;
pub mod event;
pub mod history;
pub mod keys;
pub mod pac;
pub mod powercube;
pub mod screenshot;
pub mod snapshot;
pub mod source;
pub mod ui;
pub mod worker;

#[cfg(test)]
mod tests;

use std::io::{self, Stdout, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc;
use std::sync::Arc;
use std::time::Duration;

use crossterm::event::{self as ct, Event as CtEvent};
use crossterm::terminal::{disable_raw_mode, enable_raw_mode, EnterAlternateScreen, LeaveAlternateScreen};
use crossterm::{cursor, execute};
use ratatui::backend::{Backend, CrosstermBackend};
use ratatui::Terminal;

use crate::clock::{stop, Clock};
use app::{App, LinkView};
use event::{Event, ToWorker};
use source::DeviceSource;
use worker::LinkWorker;

/// How often the screen is redrawn when nothing else happens (ages, highlights).
pub const TICK: Duration = Duration::from_millis(100);

/// Shortest time between two redraws for worker reports (10 frames a
/// second; a key is drawn at once). Every report still reaches the state
/// and its history (the charts): only the screen is refreshed less often
/// than a 20 Hz poll, which halves the drawing's share of the CPU.
pub const FRAME: Duration = Duration::from_millis(100);

/// One link to open: its name for the status bar and its device sources.
pub struct LinkPlan {
    pub name: String,
    pub sources: Vec<Box<dyn DeviceSource>>,
    /// How to open the link again when it is lost (`None`: never, e.g. the
    /// in-process simulator, which cannot go away).
    pub reopen: Option<worker::Reopen>,
}

/// The dashboard ended on SIGTERM or SIGHUP, after halting what it moved;
/// the binary exits 128 + `signal`, as a shell reports a process killed by it.
#[derive(Debug, thiserror::Error)]
#[error("{}: halted what the dashboard moved and quit", stop::signal_name(*.signal))]
pub struct Terminated {
    pub signal: i32,
}

/// Set while the terminal is in raw mode on the alternate screen.
static TERMINAL_TAKEN: AtomicBool = AtomicBool::new(false);

/// Leaves raw mode and the alternate screen, once: leaving the alternate
/// screen twice would move the cursor back over what was printed between
/// (a panic message, say).
pub fn restore_terminal() {
    if TERMINAL_TAKEN.swap(false, Ordering::SeqCst) {
        let _ = disable_raw_mode();
        let _ = execute!(io::stdout(), LeaveAlternateScreen, cursor::Show);
    }
}

struct TerminalGuard;

impl Drop for TerminalGuard {
    fn drop(&mut self) {
        restore_terminal();
    }
}

/// Records every panic as a reason to stop (the UI loop then halts what
/// the dashboard moved), and restores the terminal before the previous hook
/// prints a UI-thread panic (so the message lands on a normal screen). A
/// worker's panic is not printed over the screen: the worker reports it.
fn install_panic_hook() {
    let ui_thread = std::thread::current().id();
    let default = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        stop::note_panic(&crate::device::supervisor::describe_panic(info));
        if std::thread::current().id() == ui_thread {
            restore_terminal();
            default(info);
        }
    }));
}

/// Runs the dashboard until the user quits; chart snapshots (`p`) go
/// into `snapshot_dir`.
pub fn run(plans: Vec<LinkPlan>, rate: f64, snapshot_dir: PathBuf, clock: Arc<dyn Clock>) -> anyhow::Result<()> {
    install_panic_hook();
    // SIGTERM and SIGHUP (terminal closed, SSH dropped), and SIGINT / SIGQUIT
    // sent with kill, would end the dashboard in raw mode with an axis it
    // started still moving: from here they are recorded, and the UI loop,
    // which wakes at least every TICK, halts what it moved and quits.
    stop::arm()?;
    enable_raw_mode()?;
    TERMINAL_TAKEN.store(true, Ordering::SeqCst);
    let _guard = TerminalGuard;
    execute!(io::stdout(), EnterAlternateScreen, cursor::Hide)?;
    let mut terminal: Terminal<CrosstermBackend<Stdout>> = Terminal::new(CrosstermBackend::new(io::stdout()))?;
    terminal.clear()?;
    let r = run_loop(&mut terminal, plans, rate, &snapshot_dir, clock);
    drop(terminal);
    r
}

/// Spawns the workers and merges keys, worker reports and ticks into one
/// stream of [`Event`]s for the [`App`]; draws after each batch.
pub fn run_loop<B: Backend>(
    terminal: &mut Terminal<B>,
    plans: Vec<LinkPlan>,
    rate: f64,
    snapshot_dir: &Path,
    clock: Arc<dyn Clock>,
) -> anyhow::Result<()>
where
    B::Error: Send + Sync + 'static,
{
    run_with_keys(terminal, plans, rate, snapshot_dir, clock, read_keys)
}

/// Keys come from their own thread so that a slow draw never drops one.
/// Once the terminal is restored (a panic, the end) the thread stops: what
/// is typed then is the shell's.
fn read_keys(key_tx: mpsc::Sender<Event>) -> io::Result<()> {
    std::thread::Builder::new().name("axisctl-keys".into()).spawn(move || loop {
        if !TERMINAL_TAKEN.load(Ordering::SeqCst) {
            return;
        }
        match ct::poll(TICK) {
            Ok(true) => match ct::read() {
                Ok(CtEvent::Key(k)) => {
                    if key_tx.send(Event::Key(k)).is_err() {
                        return;
                    }
                }
                Ok(_) => {}
                Err(_) => return,
            },
            Ok(false) => {}
            Err(_) => return,
        }
    })?;
    Ok(())
}

/// The dashboard ended on a panic or a failed draw, after halting what it
/// moved (`why` says what happened).
#[derive(Debug, thiserror::Error)]
#[error("{why}: halted what the dashboard moved and quit")]
pub struct Stopped {
    pub why: String,
}

/// How the UI loop ended (a stop other than a signal is in `App::stopped`).
enum End {
    Quit,
    Signal(i32),
}

/// [`run_loop`] with the keys from `keys`, which gets the sender of the
/// event stream (tests script them). A panic of the UI thread halts what
/// the dashboard moved before it goes on; so do a failed draw and a panic
/// on any other thread, which end the dashboard with [`Stopped`].
pub fn run_with_keys<B: Backend>(
    terminal: &mut Terminal<B>,
    plans: Vec<LinkPlan>,
    rate: f64,
    snapshot_dir: &Path,
    clock: Arc<dyn Clock>,
    keys: impl FnOnce(mpsc::Sender<Event>) -> io::Result<()>,
) -> anyhow::Result<()>
where
    B::Error: Send + Sync + 'static,
{
    let (tx, rx) = mpsc::channel::<Event>();
    let mut links = Vec::new();
    let mut senders = Vec::new();
    let mut handles = Vec::new();
    for (i, plan) in plans.into_iter().enumerate() {
        let families = plan.sources.iter().map(|s| s.family()).collect();
        links.push(LinkView::new(plan.name, families, rate));
        let mut w = LinkWorker::new(i, plan.sources, Arc::clone(&clock), rate);
        if let Some(reopen) = plan.reopen {
            w = w.with_reopen(reopen);
        }
        let (wtx, h) = worker::spawn(w, tx.clone());
        senders.push(wtx);
        handles.push(h);
    }
    keys(tx.clone())?;
    drop(tx);
    let mut app = App::new(links, rate, clock.now());
    app.log(app::Level::Info, "press ? for the keys, space to halt everything");
    let ended = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        ui_loop(terminal, &mut app, &rx, &senders, &clock, snapshot_dir)
    }));
    let end = match ended {
        Ok(end) => end,
        Err(payload) => {
            // The UI thread panicked: the workers still run, so they halt
            // what the dashboard moved before the panic goes on. With nothing
            // to halt it goes on at once: the terminal is the shell's again,
            // and the key reader must not live on to eat what is typed there.
            let why = format!("the dashboard panicked ({})", worker::panic_text(payload.as_ref()));
            if !app.moved.is_empty() {
                dispatch(&senders, app.halt_moved_and_quit(&why));
                finish(&senders, handles);
                let _ = writeln!(io::stderr(), "axisctl: {why}: halted what the dashboard moved");
            }
            std::panic::resume_unwind(payload)
        }
    };
    finish(&senders, handles);
    match (end, app.stopped.take()) {
        (End::Signal(signal), _) => Err(Terminated { signal }.into()),
        (End::Quit, Some(why)) => Err(Stopped { why }.into()),
        (End::Quit, None) => Ok(()),
    }
}

/// Tells every worker to quit after what is queued (the halts a stop asked
/// for), and waits for them, but not forever: a dead link must not hang it.
fn finish(senders: &[mpsc::Sender<ToWorker>], handles: Vec<std::thread::JoinHandle<()>>) {
    for s in senders {
        let _ = s.send(ToWorker::Quit);
    }
    let deadline = std::time::Instant::now() + Duration::from_secs(2);
    for h in handles {
        while !h.is_finished() && std::time::Instant::now() < deadline {
            std::thread::sleep(Duration::from_millis(5));
        }
    }
}

/// Sends what the App asks to the workers; a worker that is gone has
/// reported why, so a failed send is not an error here.
fn dispatch(senders: &[mpsc::Sender<ToWorker>], outs: Vec<app::Outgoing>) {
    for out in outs {
        let _ = senders[out.link].send(out.msg);
    }
}

fn ui_loop<B: Backend>(
    terminal: &mut Terminal<B>,
    app: &mut App,
    rx: &mpsc::Receiver<Event>,
    senders: &[mpsc::Sender<ToWorker>],
    clock: &Arc<dyn Clock>,
    snapshot_dir: &Path,
) -> End
where
    B::Error: Send + Sync + 'static,
{
    // For the smoke test that a panic restores the terminal: `!` panics the
    // UI thread when this variable is set, and is unbound otherwise.
    let panic_key = std::env::var_os("AXISCTL_TEST_PANIC_KEY").is_some();
    // Worker reports come a hundred times a second and more; the screen is
    // redrawn at most every FRAME for them, at once for a key.
    let mut drawn_at: Option<std::time::Instant> = None;
    let mut key_pressed = true;
    loop {
        // Before drawing: after SIGHUP the terminal is gone and a draw fails.
        if let Some(signal) = stop::caught() {
            dispatch(senders, app.handle(Event::Terminate(signal)));
            return End::Signal(signal);
        }
        // A panic on a thread of this process that did not report it itself.
        if let (Some(what), None) = (stop::panic_failure(), &app.stopped) {
            dispatch(senders, app.handle(Event::Stop(format!("a thread panicked ({what})"))));
            return End::Quit;
        }
        let since = drawn_at.map(|t| t.elapsed());
        let wait = if key_pressed || since.is_none_or(|s| s >= FRAME) {
            if let Err(e) = terminal.draw(|f| ui::draw(f, app)) {
                // The terminal went away with its SIGHUP on the way: halt first.
                std::thread::sleep(Duration::from_millis(50));
                if stop::caught().is_some() {
                    continue;
                }
                // Nobody sees the screen: what the dashboard moved must not
                // go on unwatched.
                dispatch(senders, app.handle(Event::Stop(format!("the screen cannot be drawn ({e})"))));
                return End::Quit;
            }
            drawn_at = Some(std::time::Instant::now());
            TICK
        } else {
            // Something is not on screen yet: come back when the frame is due.
            FRAME - since.unwrap_or_default()
        };
        let first = match rx.recv_timeout(wait) {
            Ok(ev) => Some(ev),
            Err(mpsc::RecvTimeoutError::Timeout) => None,
            Err(mpsc::RecvTimeoutError::Disconnected) => return End::Quit,
        };
        let mut batch: Vec<Event> = first.into_iter().collect();
        batch.extend(rx.try_iter().take(1000));
        batch.push(Event::Tick(clock.now()));
        key_pressed = batch.iter().any(|ev| matches!(ev, Event::Key(_)));
        for ev in batch {
            if let Event::Key(k) = &ev {
                if panic_key && k.code == ct::KeyCode::Char('!') {
                    panic!("test panic requested with AXISCTL_TEST_PANIC_KEY");
                }
            }
            dispatch(senders, app.handle(ev));
        }
        // `p`: the App asked for its chart on disk; it hears back at once.
        if let Some(req) = app.snapshot.take() {
            let r = snapshot::write(snapshot_dir, &req, std::time::SystemTime::now());
            dispatch(senders, app.handle(Event::Saved(r.map(|p| p.display().to_string()).map_err(|e| e.to_string()))));
        }
        if app.quit {
            return End::Quit;
        }
    }
}
