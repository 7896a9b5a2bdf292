//! The right-hand pane: the selected device in full, flag words decoded
//! flag by flag (errors red, warnings yellow, information plain).

use ratatui::layout::{Constraint, Layout, Rect};
use ratatui::style::{Modifier, Style};
use ratatui::text::{Line, Span};
use ratatui::widgets::{Block, Paragraph};
use ratatui::Frame;

use super::{BOLD, CHANGED, DIM, GREEN, RED, YELLOW};
use crate::proto::cdios::table::{self as cdios_table, Class};
use crate::proto::pac::table::{self as pac_table, ExtAxisStatus};
use crate::proto::powercube::flags::{FlagClass, CUBE_STATE};
use crate::tui::app::{App, DeviceView};
use crate::tui::source::{CdiosSnap, CubeSnap, DeviceKey, PacAxisSnap, PacCtrlSnap, Snapshot};

pub fn draw(f: &mut Frame, app: &App, area: Rect) {
    let Some(d) = app.selected() else {
        let p = Paragraph::new(Line::styled("no device selected", DIM)).block(Block::bordered().title(" Detail "));
        f.render_widget(p, area);
        return;
    };
    let link = &app.links[d.link];
    let stale = app.stale(d);
    let mut title =
        vec![Span::styled(format!(" {} ", title_of(d)), BOLD), Span::styled(format!("· {} ", link.name), DIM)];
    if stale.is_some() {
        title.push(Span::styled(" STALE ", YELLOW.add_modifier(Modifier::REVERSED | Modifier::BOLD)));
    }
    let block = Block::bordered().title(Line::from(title));
    let inner = block.inner(area);
    f.render_widget(block, area);
    let mut top: Vec<Line> = Vec::new();
    if let Some(why) = &stale {
        let age = d
            .ok_at
            .map(|t| format!("last good data {:.1} s ago", app.now.saturating_duration_since(t).as_secs_f64()))
            .unwrap_or_else(|| "no data yet".into());
        top.push(Line::from(vec![
            Span::styled(" STALE ", YELLOW.add_modifier(Modifier::REVERSED | Modifier::BOLD)),
            Span::styled(format!(" {age}; values below are old"), YELLOW),
        ]));
        // The reason in full, on up to two lines.
        let w = inner.width.max(10) as usize;
        let chars: Vec<char> = why.chars().collect();
        for chunk in chars.chunks(w).take(2) {
            top.push(Line::styled(chunk.iter().collect::<String>(), YELLOW));
        }
    }
    let Some(snap) = &d.snap else {
        if stale.is_none() {
            top.push(Line::styled("waiting for the first answer…", DIM));
        }
        f.render_widget(Paragraph::new(top), inner);
        return;
    };
    let v = Values { app, d, stale: stale.is_some() };
    match snap {
        Snapshot::Cube(c) => cube(f, &v, c, top, inner),
        Snapshot::PacController(p) => {
            top.extend(pac_controller_lines(&v, p));
            f.render_widget(Paragraph::new(top), inner);
        }
        Snapshot::PacAxis(a) => pac_axis(f, &v, a, top, inner),
        Snapshot::Cdios(c) => cdios(f, &v, c, top, inner),
    }
}

fn title_of(d: &DeviceView) -> String {
    match (&d.key, &d.snap) {
        (DeviceKey::Cube(m), Some(Snapshot::Cube(c))) => {
            format!("PowerCube module {m} ({})", if c.linear { "linear" } else { "rotary" })
        }
        (k, _) => k.label(),
    }
}

/// How values are styled: highlighted when just changed, dim when stale.
struct Values<'a> {
    app: &'a App,
    d: &'a DeviceView,
    stale: bool,
}

impl Values<'_> {
    fn style(&self, field: &str) -> Style {
        if self.stale {
            DIM
        } else if self.app.is_fresh_change(self.d, field) {
            CHANGED
        } else {
            Style::new()
        }
    }

    /// `Label        value unit    extra`, in columns.
    fn line(&self, label: &str, field: &str, value: String, extra: String) -> Line<'static> {
        let (value, unit) = match value.trim_start().split_once(' ') {
            Some((v, u)) => (v.to_string(), u.to_string()),
            None => (value.trim_start().to_string(), String::new()),
        };
        Line::from(vec![
            Span::raw(format!("{label:<13}")),
            Span::styled(format!("{value:>10}"), self.style(field)),
            Span::raw(format!(" {unit:<7}")),
            Span::styled(extra.trim_start().to_string(), DIM),
        ])
    }
}

/// The unit of a jog step on the selected device (empty where it has none).
pub fn unit_of(app: &App, d: &DeviceView) -> &'static str {
    let _ = app;
    match &d.snap {
        Some(Snapshot::Cube(c)) => crate::proto::powercube::table::position_unit(c.linear),
        Some(Snapshot::Cdios(_)) => crate::proto::cdios::table::POSITION_UNIT,
        _ => "",
    }
}

/// The allowed range of a typed target, as the prompt shows it.
pub fn target_range(d: &DeviceView) -> Option<String> {
    match &d.snap {
        Some(Snapshot::Cube(c)) => Some(format!(
            "{} .. {} {}",
            c.limits.min_pos,
            c.limits.max_pos,
            crate::proto::powercube::table::position_unit(c.linear)
        )),
        Some(Snapshot::PacAxis(a)) => match (a.min_pos, a.max_pos) {
            (Some(lo), Some(hi)) => Some(format!("{lo} .. {hi}")),
            _ => None,
        },
        Some(Snapshot::Cdios(_)) => {
            let (lo, hi) = crate::tui::cdios_target_range();
            Some(format!("{lo} .. {hi} counts"))
        }
        _ => None,
    }
}

fn class_style(class: FlagClass) -> (Style, &'static str) {
    match class {
        FlagClass::Error => (RED.add_modifier(Modifier::BOLD), "error"),
        FlagClass::Warning => (YELLOW, "warning"),
        FlagClass::Info => (Style::new(), "info"),
        FlagClass::Obsolete => (DIM, "obsolete"),
    }
}

fn cube(f: &mut Frame, v: &Values, c: &CubeSnap, mut top: Vec<Line<'static>>, area: Rect) {
    let u = crate::proto::powercube::table::position_unit(c.linear);
    let l = &c.limits;
    top.push(v.line(
        "Position",
        "pos",
        format!("{:>10.4} {u}", c.pos),
        format!("limits {} .. {} {u}", l.min_pos, l.max_pos),
    ));
    top.push(v.line("Velocity", "vel", format!("{:>10.4} {u}/s", c.vel), format!("max {} {u}/s", l.max_vel)));
    top.push(v.line("Current", "cur", format!("{:>10.3} A", c.cur), format!("max {} A", l.max_cur)));
    // Firmware before 4.6.01 has no temperature and supplies (NaN): a dash.
    let measured = |x: f64, unit: &str| if x.is_nan() { "–".to_string() } else { format!("{x:.1} {unit}") };
    top.push(v.line(
        "Temperature",
        "temp",
        format!("{:>13}", measured(c.temp, "°C")),
        format!("max acc {} {u}/s²", l.max_acc),
    ));
    top.push(Line::from(vec![
        Span::raw(format!("{:<13}", "Supply")),
        Span::raw("motor "),
        Span::styled(measured(c.motor_v, "V"), v.style("motor_v")),
        Span::raw("   logic "),
        Span::styled(measured(c.logic_v, "V"), v.style("logic_v")),
    ]));
    let [values, flags] = Layout::vertical([Constraint::Length(top.len() as u16), Constraint::Min(3)]).areas(area);
    f.render_widget(Paragraph::new(top), values);
    let d = CUBE_STATE.decode(c.cube_state);
    // Room for every flag: all of them, set ones marked; else the set ones.
    let inner_w = flags.width.saturating_sub(2);
    let room = (inner_w / 34).max(1) as usize * flags.height.saturating_sub(2) as usize;
    let show_all = room >= CUBE_STATE.flags.len();
    let mut cells: Vec<(String, Style)> = CUBE_STATE
        .flags
        .iter()
        .filter(|def| show_all || c.cube_state & def.mask != 0)
        .map(|def| {
            let set = c.cube_state & def.mask != 0;
            let (style, word) = class_style(def.class);
            let mark = if !show_all {
                ""
            } else if set {
                "● "
            } else {
                "· "
            };
            let text = if set { format!("{mark}{:<22} {word}", def.name) } else { format!("{mark}{}", def.name) };
            (text, if v.stale || !set { DIM } else { style })
        })
        .collect();
    if d.unknown_bits != 0 {
        cells.push((format!("unknown bits {:#010x}", d.unknown_bits), YELLOW));
    }
    if cells.is_empty() {
        cells.push(("(no flags set)".into(), DIM));
    }
    let summary = if d.has_error() {
        Span::styled(format!(" {} error(s) ", d.errors.len()), RED.add_modifier(Modifier::REVERSED))
    } else {
        Span::raw("")
    };
    let title = Line::from(vec![
        Span::styled(format!(" CubeState {:#010x} ", c.cube_state), v.style("state").add_modifier(Modifier::BOLD)),
        summary,
    ]);
    flag_grid(f, flags, title, cells, 34);
}

/// Flags in as many columns of `col_w` as fit.
fn flag_grid(f: &mut Frame, area: Rect, title: Line<'static>, cells: Vec<(String, Style)>, col_w: u16) {
    let block = Block::bordered().title(title);
    let inner = block.inner(area);
    f.render_widget(block, area);
    let cols = (inner.width / col_w).max(1) as usize;
    let rows = cells.len().div_ceil(cols).max(1);
    let mut lines = Vec::new();
    for r in 0..rows {
        let mut spans = Vec::new();
        for c in 0..cols {
            if let Some((text, style)) = cells.get(c * rows + r) {
                spans.push(Span::styled(format!("{text:<w$}", w = col_w as usize), *style));
            }
        }
        lines.push(Line::from(spans));
    }
    if lines.len() > inner.height as usize && inner.height > 0 {
        let hidden = lines.len() - inner.height as usize + 1;
        lines.truncate(inner.height as usize - 1);
        lines.push(Line::styled(format!("… {hidden} more line(s): enlarge the terminal"), DIM));
    }
    f.render_widget(Paragraph::new(lines), inner);
}

/// A word for the operating status, for the list.
pub fn pac_status_word(status: u16) -> &'static str {
    match pac_table::mode_of_status(status) {
        Some(pac_table::Mode::Online) => "online",
        Some(pac_table::Mode::Automatic) => "automatic",
        Some(pac_table::Mode::Manual) => "manual",
        Some(pac_table::Mode::Home) => "home",
        _ => "status?",
    }
}

pub fn pac_axis_word(a: &PacAxisSnap) -> (String, Style) {
    let ext = ExtAxisStatus::decode(a.ext_status);
    if a.status == 4 {
        ("fault".into(), RED.add_modifier(Modifier::BOLD))
    } else if !ext.power_pack_ready {
        ("not ready".into(), YELLOW)
    } else if ext.positive_limit_activated || ext.negative_limit_activated {
        ("limit sw".into(), YELLOW)
    } else {
        let name = pac_table::axis_status(a.status.max(0) as u64).map_or("?", |s| s.name);
        (name.into(), if a.status == 1 { GREEN } else { Style::new() })
    }
}

fn pac_controller_lines(v: &Values, p: &PacCtrlSnap) -> Vec<Line<'static>> {
    let err_style = if p.error != 0 { RED.add_modifier(Modifier::BOLD) } else { v.style("error") };
    let err_text = if p.error == 0 { "0 (none)".to_string() } else { format!("E{:03}", p.error) };
    vec![
        v.line(
            "Status",
            "status",
            format!("{}", p.status),
            format!("  {}", pac_table::operating_status_text(p.status)),
        ),
        Line::from(vec![Span::raw(format!("{:<13}", "Error")), Span::styled(err_text, err_style)]),
        Line::from(vec![Span::raw(format!("{:<13}", "Axes")), Span::raw(p.axes.to_string())]),
    ]
}

fn pac_axis(f: &mut Frame, v: &Values, a: &PacAxisSnap, mut top: Vec<Line<'static>>, area: Rect) {
    if let Some(ctrl) = v.app.device(DeviceKey::PacController) {
        if let Some(Snapshot::PacController(p)) = &ctrl.snap {
            let cv = Values { app: v.app, d: ctrl, stale: v.app.stale(ctrl).is_some() };
            let mut l = pac_controller_lines(&cv, p);
            l.truncate(2);
            top.extend(l);
        }
    }
    let range = match (a.min_pos, a.max_pos) {
        (Some(lo), Some(hi)) => format!("   traverse {lo} .. {hi}"),
        _ => String::new(),
    };
    top.push(v.line("Position", "pos", format!("{:>12.3}", a.position), range));
    top.push(v.line("Speed", "speed", format!("{:>12.3}", a.speed), String::new()));
    top.push(v.line(
        "Status 1910",
        "status",
        format!("{:>12}", a.status),
        format!("  {}", pac_table::axis_status_text(a.status.max(0) as u64)),
    ));
    let [values, flags] = Layout::vertical([Constraint::Length(top.len() as u16), Constraint::Min(3)]).areas(area);
    f.render_widget(Paragraph::new(top), values);
    let ext = ExtAxisStatus::decode(a.ext_status);
    let dim = |s: Style| if v.stale { DIM } else { s };
    let cells = vec![
        (
            format!("power pack {}", if ext.power_pack_ready { "ready" } else { "NOT READY" }),
            dim(if ext.power_pack_ready { GREEN } else { RED.add_modifier(Modifier::BOLD) }),
        ),
        (
            format!("+ limit switch {}", if ext.positive_limit_activated { "ACTIVATED" } else { "free" }),
            dim(if ext.positive_limit_activated { YELLOW } else { Style::new() }),
        ),
        (
            format!("- limit switch {}", if ext.negative_limit_activated { "ACTIVATED" } else { "free" }),
            dim(if ext.negative_limit_activated { YELLOW } else { Style::new() }),
        ),
        (format!("axis: {}", ext.axis_status_text), dim(if ext.axis_status == 4 { RED } else { Style::new() })),
    ];
    let title = Line::styled(
        format!(" Extended status 1921 {:#010x} ", a.ext_status),
        v.style("ext").add_modifier(Modifier::BOLD),
    );
    flag_grid(f, flags, title, cells, 30);
}

fn title_again(c: &CdiosSnap, v: &Values) -> Line<'static> {
    Line::styled(
        format!(" Status bytes {:02x} {:02x} {:02x} {:02x} ", c.status[0], c.status[1], c.status[2], c.status[3]),
        v.style("status").add_modifier(Modifier::BOLD),
    )
}

pub fn cdios_word(c: &CdiosSnap) -> (String, Style) {
    let r = cdios_table::decode_status(c.status);
    if !r.errors.is_empty() {
        ("ERROR".into(), RED.add_modifier(Modifier::BOLD))
    } else if c.status[0] & 0x03 != 0 {
        ("moving".into(), GREEN)
    } else if c.status[2] & 0x80 == 0 {
        ("off".into(), YELLOW)
    } else {
        ("ok".into(), GREEN)
    }
}

fn cdios(f: &mut Frame, v: &Values, c: &CdiosSnap, mut top: Vec<Line<'static>>, area: Rect) {
    top.push(v.line("Position", "pos", format!("{} counts", c.position), String::new()));
    top.push(v.line("Setpoint", "setpoint", format!("{} counts", c.setpoint), String::new()));
    top.push(v.line("Speed", "speed", format!("{:>10}", c.speed), String::new()));
    top.push(v.line("RPM error", "rpm_error", format!("{:>10}", c.rpm_error), String::new()));
    let [values, flags] = Layout::vertical([Constraint::Length(top.len() as u16), Constraint::Min(6)]).areas(area);
    f.render_widget(Paragraph::new(top), values);
    let title = Line::styled(
        format!(" Status bytes {:02x} {:02x} {:02x} {:02x} ", c.status[0], c.status[1], c.status[2], c.status[3]),
        v.style("status").add_modifier(Modifier::BOLD),
    );
    let style_of = |fl: &cdios_table::Flag, set: bool| {
        if !set || v.stale {
            DIM
        } else if fl.class == Class::Error {
            RED.add_modifier(Modifier::BOLD)
        } else {
            Style::new()
        }
    };
    let all = cdios_table::STATUS_FLAGS;
    let block = Block::bordered().title(title);
    let inner = block.inner(flags);
    // Wide enough for the whole table: every bit, set ones bright, one
    // column per byte. Otherwise the set bits, one per line.
    if inner.width >= 4 * 33 && inner.height >= 9 {
        f.render_widget(block, flags);
        let mut lines =
            vec![Line::styled((1..=4).map(|b| format!("{:<33}", format!("status {b}"))).collect::<String>(), BOLD)];
        for bit in (0..8u8).rev() {
            let mut spans = Vec::new();
            for byte in 1..=4u8 {
                let set = c.status[byte as usize - 1] & (1 << bit) != 0;
                let mark = if set { "●" } else { "·" };
                match all.iter().find(|fl| fl.byte == byte && fl.bit == bit) {
                    Some(fl) => spans.push(Span::styled(format!("{bit} {mark} {:<29}", fl.name), style_of(fl, set))),
                    None => spans
                        .push(Span::styled(format!("{bit} {mark} {:<29}", "reserved"), if set { YELLOW } else { DIM })),
                }
            }
            lines.push(Line::from(spans));
        }
        f.render_widget(Paragraph::new(lines), inner);
        return;
    }
    let mut cells = Vec::new();
    for (i, b) in c.status.iter().enumerate() {
        let byte = i as u8 + 1;
        for bit in (0..8u8).rev().filter(|bit| b & (1 << bit) != 0) {
            match all.iter().find(|fl| fl.byte == byte && fl.bit == bit) {
                Some(fl) => cells.push((format!("S{byte}.{bit} {}", fl.name), style_of(fl, true))),
                None => cells.push((format!("S{byte}.{bit} reserved bit set"), YELLOW)),
            }
        }
    }
    if cells.is_empty() {
        cells.push(("(no bits set)".into(), DIM));
    }
    let _ = block;
    flag_grid(f, flags, title_again(c, v), cells, 36);
}
