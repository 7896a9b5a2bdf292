//! The key bindings, declared once: the key handler, the help overlay, the
//! hint line and the key table of docs/guide.md all read [`KEYS`].

use crossterm::event::{KeyCode, KeyEvent, KeyModifiers};

use crate::family::{Capability, Family};

/// What a key does.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum KeyAction {
    HaltAll,
    Up,
    Down,
    Home,
    Reset,
    Halt,
    Enable,
    Disable,
    JogPlus,
    JogMinus,
    StepSmaller,
    StepLarger,
    GoTo,
    Online,
    Offline,
    RateDown,
    RateUp,
    Rescan,
    ScrollUp,
    ScrollDown,
    Chart,
    Overview,
    Snapshot,
    Help,
    Quit,
}

pub struct KeyBinding {
    pub codes: &'static [KeyCode],
    /// How the help and the docs write the keys.
    pub keys: &'static str,
    pub action: KeyAction,
    pub help: &'static str,
    /// The hint line's word for it ("" to leave it out).
    pub short: &'static str,
    /// What a device's family must be able to do for the key to act on it
    /// (`None`: the key is about the screen, or every device).
    pub needs: Option<Capability>,
}

impl KeyBinding {
    /// Which families it applies to, from the registry ("all" for every one).
    pub fn applies(&self) -> String {
        let Some(c) = self.needs else { return "all".into() };
        let fams: Vec<_> = Family::ALL.into_iter().filter(|f| f.can(c)).map(Family::display_name).collect();
        if fams.len() == Family::ALL.len() {
            "all".into()
        } else {
            fams.join(", ")
        }
    }
}

const fn k(
    codes: &'static [KeyCode],
    keys: &'static str,
    action: KeyAction,
    help: &'static str,
    short: &'static str,
    needs: Option<Capability>,
) -> KeyBinding {
    KeyBinding { codes, keys, action, help, short, needs }
}

use KeyCode::{Char, Down, Esc, PageDown, PageUp, Up};

pub const KEYS: &[KeyBinding] = &[
    k(
        &[Char(' ')],
        "space",
        KeyAction::HaltAll,
        "HALT ALL: halt every PowerCube, PA axis and Cdios motor (any screen)",
        "HALT ALL",
        None,
    ),
    k(&[Up, Char('k')], "↑ / k", KeyAction::Up, "select the device above", "select", None),
    k(&[Down, Char('j')], "↓ / j", KeyAction::Down, "select the device below", "", None),
    k(
        &[Char('h')],
        "h",
        KeyAction::Home,
        "home (PowerCube) / reference drive (PA axis)",
        "home",
        Some(Capability::Home),
    ),
    k(&[Char('r')], "r", KeyAction::Reset, "reset: clear the error state", "reset", Some(Capability::Reset)),
    k(&[Char('s')], "s", KeyAction::Halt, "halt / stop the selected device", "stop", Some(Capability::Halt)),
    k(
        &[Char('e')],
        "e",
        KeyAction::Enable,
        "enable: switch the axis / motor on",
        "on",
        Some(Capability::EnableDisable),
    ),
    k(
        &[Char('d')],
        "d",
        KeyAction::Disable,
        "disable: switch the axis / motor off",
        "off",
        Some(Capability::EnableDisable),
    ),
    k(&[Char('+'), Char('=')], "+", KeyAction::JogPlus, "jog forward by the step size", "jog", Some(Capability::Jog)),
    k(&[Char('-')], "-", KeyAction::JogMinus, "jog backward by the step size", "", Some(Capability::Jog)),
    k(&[Char('[')], "[", KeyAction::StepSmaller, "smaller jog step", "step", None),
    k(&[Char(']')], "]", KeyAction::StepLarger, "larger jog step", "", None),
    k(
        &[Char('g')],
        "g",
        KeyAction::GoTo,
        "move to a typed target, checked against the limits like the CLI",
        "go to",
        Some(Capability::GoTo),
    ),
    k(
        &[Char('o')],
        "o",
        KeyAction::Online,
        "switch the PA-CONTROL to online mode",
        "online",
        Some(Capability::OnlineOffline),
    ),
    k(
        &[Char('f')],
        "f",
        KeyAction::Offline,
        "switch the PA-CONTROL offline",
        "offline",
        Some(Capability::OnlineOffline),
    ),
    k(&[Char('<')], "<", KeyAction::RateDown, "poll slower", "rate", None),
    k(&[Char('>')], ">", KeyAction::RateUp, "poll faster", "", None),
    k(&[Char('n')], "n", KeyAction::Rescan, "rescan the links for devices that were missing", "rescan", None),
    k(&[PageUp], "PgUp", KeyAction::ScrollUp, "scroll the event pane back", "events", None),
    k(&[PageDown], "PgDn", KeyAction::ScrollDown, "scroll the event pane forward", "", None),
    k(&[Char('c')], "c", KeyAction::Chart, "chart of the selected device, last 30 s", "chart", None),
    k(&[Char('p')], "p", KeyAction::Snapshot, "write the chart to SVG", "", None),
    k(&[Char('v')], "v", KeyAction::Overview, "overview: every device in one table", "overview", None),
    k(&[Char('?')], "?", KeyAction::Help, "this help (any key closes it)", "help", None),
    k(&[Char('q'), Esc], "q / Esc", KeyAction::Quit, "quit (the devices keep doing what they do)", "quit", None),
];

/// The action bound to a key press. Ctrl-C quits like `q`.
pub fn lookup(key: &KeyEvent) -> Option<KeyAction> {
    if key.modifiers.contains(KeyModifiers::CONTROL) {
        return (key.code == Char('c')).then_some(KeyAction::Quit);
    }
    KEYS.iter().find(|b| b.codes.contains(&key.code)).map(|b| b.action)
}

pub fn binding(action: KeyAction) -> &'static KeyBinding {
    KEYS.iter().find(|b| b.action == action).expect("every action has a binding")
}

/// The key table of docs/guide.md, generated (a test keeps the guide in step).
pub fn markdown_table() -> String {
    let mut s = String::from("| key | what it does | applies to |\n|---|---|---|\n");
    for b in KEYS {
        s.push_str(&format!("| `{}` | {} | {} |\n", b.keys, b.help, b.applies()));
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_key_is_bound_once() {
        let mut seen = Vec::new();
        for b in KEYS {
            for c in b.codes {
                assert!(!seen.contains(c), "{c:?} bound twice");
                seen.push(*c);
            }
        }
        assert_eq!(lookup(&KeyEvent::new(Char(' '), KeyModifiers::NONE)), Some(KeyAction::HaltAll));
        assert_eq!(lookup(&KeyEvent::new(Char('c'), KeyModifiers::CONTROL)), Some(KeyAction::Quit));
        assert_eq!(lookup(&KeyEvent::new(Char('x'), KeyModifiers::NONE)), None);
    }
}
