//! The key bindings, declared once: the key handler, the help overlay, the
//! hint line and the key table of docs/guide.md all read [`KEYS`].

use crossterm::event::{KeyCode, KeyEvent, KeyModifiers};

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
    ScrollUp,
    ScrollDown,
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
    /// Which families it applies to ("all" for every one).
    pub applies: &'static str,
}

const fn k(
    codes: &'static [KeyCode],
    keys: &'static str,
    action: KeyAction,
    help: &'static str,
    short: &'static str,
    applies: &'static str,
) -> KeyBinding {
    KeyBinding { codes, keys, action, help, short, applies }
}

use KeyCode::{Char, Down, Esc, PageDown, PageUp, Up};

pub const KEYS: &[KeyBinding] = &[
    k(
        &[Char(' ')],
        "space",
        KeyAction::HaltAll,
        "HALT ALL: halt every PowerCube, PA axis and Cdios motor (any screen)",
        "HALT ALL",
        "all",
    ),
    k(&[Up, Char('k')], "↑ / k", KeyAction::Up, "select the device above", "select", "all"),
    k(&[Down, Char('j')], "↓ / j", KeyAction::Down, "select the device below", "", "all"),
    k(&[Char('h')], "h", KeyAction::Home, "home (PowerCube) / reference drive (PA axis)", "home", "PowerCube, PA axis"),
    k(&[Char('r')], "r", KeyAction::Reset, "reset: clear the error state", "reset", "PowerCube, PA-CONTROL, Cdios"),
    k(&[Char('s')], "s", KeyAction::Halt, "halt / stop the selected device", "stop", "all"),
    k(&[Char('e')], "e", KeyAction::Enable, "enable: switch the axis / motor on", "on", "PA axis, Cdios"),
    k(&[Char('d')], "d", KeyAction::Disable, "disable: switch the axis / motor off", "off", "PA axis, Cdios"),
    k(
        &[Char('+'), Char('=')],
        "+",
        KeyAction::JogPlus,
        "jog forward by the step size",
        "jog",
        "PowerCube, PA axis, Cdios",
    ),
    k(&[Char('-')], "-", KeyAction::JogMinus, "jog backward by the step size", "", "PowerCube, PA axis, Cdios"),
    k(&[Char('[')], "[", KeyAction::StepSmaller, "smaller jog step", "step", "all"),
    k(&[Char(']')], "]", KeyAction::StepLarger, "larger jog step", "", "all"),
    k(
        &[Char('g')],
        "g",
        KeyAction::GoTo,
        "move to a typed target, checked against the limits like the CLI",
        "go to",
        "PowerCube, PA axis, Cdios",
    ),
    k(&[Char('o')], "o", KeyAction::Online, "switch the PA-CONTROL to online mode", "online", "PA-CONTROL"),
    k(&[Char('f')], "f", KeyAction::Offline, "switch the PA-CONTROL offline", "offline", "PA-CONTROL"),
    k(&[Char('<')], "<", KeyAction::RateDown, "poll slower", "rate", "all"),
    k(&[Char('>')], ">", KeyAction::RateUp, "poll faster", "", "all"),
    k(&[PageUp], "PgUp", KeyAction::ScrollUp, "scroll the event pane back", "events", "all"),
    k(&[PageDown], "PgDn", KeyAction::ScrollDown, "scroll the event pane forward", "", "all"),
    k(&[Char('?')], "?", KeyAction::Help, "this help (any key closes it)", "help", "all"),
    k(&[Char('q'), Esc], "q / Esc", KeyAction::Quit, "quit (the devices keep doing what they do)", "quit", "all"),
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
        s.push_str(&format!("| `{}` | {} | {} |\n", b.keys, b.help, b.applies));
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
