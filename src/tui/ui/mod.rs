//! Drawing: pure functions of [`App`]. Nothing here changes state or does I/O.
//!
//! Layout: the device list on the left, the selected device's detail on the
//! right above the event pane, the status bar (link health, key hints) at
//! the bottom; the help and the target prompt are drawn over it. The
//! overview (`v`) puts one table of every device in the place of the list
//! and the detail; the chart (`c`) goes below the detail or the table, or
//! in the place of the detail (of the event pane under the table) when
//! the screen is too low for both.

pub mod cdios;
mod chart;
mod detail;
mod overview;
pub mod pac;
pub mod pane;
pub mod powercube;

use crate::address::Address;
use ratatui::layout::{Constraint, Layout, Rect};
use ratatui::style::{Color, Modifier, Style};
use ratatui::text::{Line, Span};
use ratatui::widgets::{Block, Borders, Clear, Paragraph, Wrap};
use ratatui::Frame;

use super::app::{App, DeviceView, Level, Mode};
use super::keys::{self, KeyBinding, KEYS};

pub(crate) const RED: Style = Style::new().fg(Color::Red);
pub(crate) const YELLOW: Style = Style::new().fg(Color::Yellow);
pub(crate) const GREEN: Style = Style::new().fg(Color::Green);
pub(crate) const DIM: Style = Style::new().fg(Color::DarkGray);
pub(crate) const BOLD: Style = Style::new().add_modifier(Modifier::BOLD);
/// A value that changed since the previous poll.
pub(crate) const CHANGED: Style = Style::new().fg(Color::Black).bg(Color::Cyan);

pub fn draw(f: &mut Frame, app: &App) {
    let area = f.area();
    let status = status_lines(app, area.width);
    let [main, bar] = Layout::vertical([Constraint::Min(6), Constraint::Length(status.len() as u16)]).areas(area);
    let events_h = (main.height / 3).clamp(4, 14);
    // Where the target prompt goes: over the lower part of the values.
    let prompt_area =
        if app.overview { draw_overview(f, app, main, events_h) } else { draw_panes(f, app, main, events_h) };
    f.render_widget(Paragraph::new(status), bar);
    match &app.mode {
        Mode::Help => draw_help(f, area),
        Mode::Target(text) => draw_prompt(f, app, prompt_area, text),
        Mode::Normal => {}
    }
}

/// Rows a chart needs to be worth drawing next to something else.
const CHART_MIN: u16 = 12;
/// Rows the detail keeps above a chart.
const DETAIL_MIN: u16 = 14;

/// The list, the detail (and the chart), the events.
fn draw_panes(f: &mut Frame, app: &App, main: Rect, events_h: u16) -> Rect {
    let list_w = if main.width >= 120 { 30 } else { 24 };
    let [list, right] = Layout::horizontal([Constraint::Length(list_w), Constraint::Min(20)]).areas(main);
    let [upper, events] = Layout::vertical([Constraint::Min(8), Constraint::Length(events_h)]).areas(right);
    draw_list(f, app, list);
    draw_events(f, app, events);
    if !app.chart {
        detail::draw(f, app, upper);
    } else if upper.height >= DETAIL_MIN + CHART_MIN {
        let [detail_area, chart_area] = Layout::vertical([Constraint::Fill(1), Constraint::Fill(1)]).areas(upper);
        detail::draw(f, app, detail_area);
        chart::draw(f, app, chart_area);
    } else {
        chart::draw(f, app, upper);
    }
    upper
}

/// The overview table over the full width, the chart and the events below.
fn draw_overview(f: &mut Frame, app: &App, main: Rect, events_h: u16) -> Rect {
    let table_h = overview::height(app).min(main.height.saturating_sub(if app.chart { 6 } else { events_h }));
    if !app.chart {
        let [table, events] = Layout::vertical([Constraint::Min(table_h), Constraint::Length(events_h)]).areas(main);
        overview::draw(f, app, table);
        draw_events(f, app, events);
        return table;
    }
    let [table, rest] = Layout::vertical([Constraint::Length(table_h), Constraint::Min(0)]).areas(main);
    overview::draw(f, app, table);
    if rest.height >= CHART_MIN + events_h {
        let [chart_area, events] =
            Layout::vertical([Constraint::Min(CHART_MIN), Constraint::Length(events_h)]).areas(rest);
        chart::draw(f, app, chart_area);
        draw_events(f, app, events);
    } else {
        chart::draw(f, app, rest);
    }
    table
}

/// A short word for the list: what most needs attention.
pub(super) fn summary(app: &App, d: &DeviceView) -> (String, Style) {
    if app.stale(d).is_some() {
        return ("STALE".into(), YELLOW.add_modifier(Modifier::REVERSED));
    }
    let Some(snap) = &d.snap else { return ("…".into(), DIM) };
    snap.summary()
}

fn group_title(key: Address) -> &'static str {
    key.family().display_name()
}

fn draw_list(f: &mut Frame, app: &App, area: Rect) {
    let mut lines = Vec::new();
    let mut group = None;
    let mut selected_line = 0;
    for (i, d) in app.devices.iter().enumerate() {
        let g = group_title(d.key);
        if group != Some(g) {
            group = Some(g);
            lines.push(Line::styled(g, BOLD));
        }
        let name = match d.key {
            Address::PowerCube { module: m } => format!("module {m}"),
            Address::Pac { axis: None } => "controller".into(),
            Address::Pac { axis: Some(a) } => format!("axis {a}"),
            Address::Cdios { node, module } => format!("node {node} mod {module}"),
        };
        let (word, style) = summary(app, d);
        let sel = i == app.selected;
        if sel {
            selected_line = lines.len();
        }
        let w = area.width.saturating_sub(2) as usize;
        let left = format!("{}{name}", if sel { "▶ " } else { "  " });
        let pad = w.saturating_sub(left.chars().count() + word.chars().count()).max(1);
        let name_style = if sel { BOLD.add_modifier(Modifier::REVERSED) } else { Style::new() };
        lines.push(Line::from(vec![
            Span::styled(left, name_style),
            Span::raw(" ".repeat(pad)),
            Span::styled(word, style),
        ]));
    }
    if app.devices.is_empty() {
        let waiting = app.links.iter().any(|l| !l.discovered);
        lines.push(Line::styled(if waiting { "scanning…" } else { "no devices" }, DIM));
    }
    let inner_h = area.height.saturating_sub(2) as usize;
    let scroll = selected_line.saturating_sub(inner_h.saturating_sub(1));
    let p = Paragraph::new(lines).scroll((scroll as u16, 0)).block(Block::bordered().title(" Devices "));
    f.render_widget(p, area);
}

fn draw_events(f: &mut Frame, app: &App, area: Rect) {
    let inner_w = area.width.saturating_sub(2).max(1) as usize;
    let inner_h = area.height.saturating_sub(2) as usize;
    let end = app.events.len().saturating_sub(app.scroll);
    // Newest at the bottom, long lines wrapped: take lines from the newest
    // back until the pane is full.
    let mut rows = 0;
    let mut start = end;
    while start > 0 {
        let e = &app.events[start - 1];
        let need = (8 + e.shown().chars().count()).div_ceil(inner_w).max(1);
        if rows + need > inner_h && rows > 0 {
            break;
        }
        rows += need;
        start -= 1;
    }
    let lines: Vec<Line> = app
        .events
        .range(start..end)
        .map(|e| {
            let t = e.at.saturating_duration_since(app.started).as_secs_f64();
            let style = match e.level {
                Level::Info => Style::new(),
                Level::Warn => YELLOW,
                Level::Error => RED,
            };
            Line::from(vec![
                Span::styled(format!("{:02}:{:04.1} ", (t / 60.0) as u64, t % 60.0), DIM),
                Span::styled(e.shown(), style),
            ])
        })
        .collect();
    let skip = rows.saturating_sub(inner_h);
    let title = if app.scroll > 0 { format!(" Events (↑{} — PgDn) ", app.scroll) } else { " Events ".into() };
    let p =
        Paragraph::new(lines).wrap(Wrap { trim: false }).scroll((skip as u16, 0)).block(Block::bordered().title(title));
    f.render_widget(p, area);
}

/// Per link: name, achieved / wanted rate, time per round, and the answer /
/// timeout / error counters; then the key hints. Links share a line when
/// they fit.
fn status_lines(app: &App, width: u16) -> Vec<Line<'static>> {
    let mut per_link: Vec<Vec<Span<'static>>> = Vec::new();
    for l in &app.links {
        let mut spans = vec![Span::styled(l.name.clone(), BOLD), Span::raw(" ")];
        if let Some(why) = &l.ended {
            spans.push(Span::styled(format!("DOWN: {why}"), RED.add_modifier(Modifier::REVERSED)));
            per_link.push(spans);
            continue;
        }
        let rate = match l.achieved_hz() {
            Some(hz) => {
                let style = if hz < l.rate * 0.9 { YELLOW } else { GREEN };
                Span::styled(format!("{hz:.1}/{} Hz", l.rate), style)
            }
            None => Span::styled(format!("–/{} Hz", l.rate), DIM),
        };
        spans.push(rate);
        if let Some(b) = l.busy {
            spans.push(Span::styled(format!(" {:.1} ms", b.as_secs_f64() * 1e3), DIM));
        }
        spans.push(Span::raw(format!(" ok {}", l.answers)));
        spans.push(Span::styled(format!(" t/o {}", l.timeouts), if l.timeouts > 0 { YELLOW } else { Style::new() }));
        spans.push(Span::styled(format!(" err {}", l.errors), if l.errors > 0 { RED } else { Style::new() }));
        per_link.push(spans);
    }
    let mut lines: Vec<Line<'static>> = Vec::new();
    let total: usize = per_link.iter().map(|s| spans_width(s) + 3).sum();
    if total <= width as usize {
        let mut joined = Vec::new();
        for (i, s) in per_link.into_iter().enumerate() {
            if i > 0 {
                joined.push(Span::styled(" │ ", DIM));
            }
            joined.extend(s);
        }
        lines.push(Line::from(joined));
    } else {
        lines.extend(per_link.into_iter().map(Line::from));
    }
    if let Some(notice) = app.notice() {
        lines.push(Line::styled(notice.to_string(), BOLD));
    }
    lines.push(hint_line(app, width));
    lines
}

fn spans_width(spans: &[Span]) -> usize {
    spans.iter().map(|s| s.content.chars().count()).sum()
}

/// `space HALT ALL  ↑↓ select  h home ...`, as many as fit, from [`KEYS`].
fn hint_line(app: &App, width: u16) -> Line<'static> {
    let mut groups: Vec<(String, String)> = Vec::new();
    for b in KEYS {
        let key = match b.codes[0] {
            crossterm::event::KeyCode::Char(' ') => "space".to_string(),
            crossterm::event::KeyCode::Char(c) => c.to_string(),
            crossterm::event::KeyCode::Up => "↑".into(),
            crossterm::event::KeyCode::Down => "↓".into(),
            crossterm::event::KeyCode::PageUp => "PgUp".into(),
            crossterm::event::KeyCode::PageDown => "/PgDn".into(),
            other => format!("{other}"),
        };
        if b.short.is_empty() {
            if let Some(last) = groups.last_mut() {
                last.0.push_str(&key);
            }
        } else {
            let mut word = b.short.to_string();
            if b.action == keys::KeyAction::StepSmaller {
                if let (Some(step), Some(d)) = (app.jog_step(), app.selected()) {
                    word = format!("step {step} {}", detail::unit_of(d)).trim_end().to_string();
                }
            }
            groups.push((key, word));
        }
    }
    // What a newcomer needs first: halt-all, help, quit.
    let first = |w: &str| w == "HALT ALL" || w == "help" || w == "quit";
    let (mut ordered, rest): (Vec<_>, Vec<_>) = groups.into_iter().partition(|(_, w)| first(w));
    ordered.extend(rest);
    let mut spans = Vec::new();
    let mut used = 0;
    for (i, (k, w)) in ordered.into_iter().enumerate() {
        let len = k.chars().count() + w.chars().count() + 3;
        if used + len > width as usize {
            continue;
        }
        used += len;
        let key_style = if i == 0 { RED.add_modifier(Modifier::REVERSED | Modifier::BOLD) } else { BOLD };
        spans.push(Span::styled(k, key_style));
        spans.push(Span::raw(format!(" {w}  ")));
    }
    Line::from(spans)
}

fn centered(area: Rect, w: u16, h: u16) -> Rect {
    let w = w.min(area.width);
    let h = h.min(area.height);
    Rect { x: area.x + (area.width - w) / 2, y: area.y + (area.height - h) / 2, width: w, height: h }
}

fn draw_help(f: &mut Frame, area: Rect) {
    // One row per binding; on a short screen a binding and its partner (the
    // next one, which has no hint word of its own: ↓ after ↑, - after +)
    // share a row, so that every key stays visible at 80x24.
    let compact = KEYS.len() as u16 + 2 >= area.height;
    let mut rows: Vec<(String, String, &KeyBinding)> = Vec::new();
    for b in KEYS {
        match rows.last_mut() {
            Some((keys, help, _)) if compact && b.short.is_empty() => {
                keys.push_str(", ");
                keys.push_str(b.keys);
                help.push_str(" / ");
                help.push_str(b.help);
            }
            _ => rows.push((b.keys.to_string(), b.help.to_string(), b)),
        }
    }
    let key_w = rows.iter().map(|(k, _, _)| k.chars().count()).max().unwrap_or(0);
    let wide = area.width >= 120;
    let lines: Vec<Line> = rows
        .into_iter()
        .map(|(keys, help, b)| {
            let style = if b.keys == "space" { RED } else { BOLD };
            let mut spans = vec![Span::styled(format!("{keys:>key_w$}  "), style), Span::raw(help)];
            if wide {
                spans.push(Span::styled(format!("  [{}]", b.applies()), DIM));
            }
            Line::from(spans)
        })
        .collect();
    let text_w = lines.iter().map(|l| l.width()).max().unwrap_or(0) as u16;
    // Rows after wrapping, so that the last key is not cut off.
    let inner = usize::from((text_w + 4).min(area.width).saturating_sub(2).max(1));
    let height: usize = lines.iter().map(|l| l.width().div_ceil(inner).max(1)).sum();
    let r = centered(area, text_w + 4, height as u16 + 2);
    f.render_widget(Clear, r);
    let block = Block::bordered().title(" Keys (any key closes) ").border_style(BOLD);
    f.render_widget(Paragraph::new(lines).block(block).wrap(Wrap { trim: false }), r);
}

fn draw_prompt(f: &mut Frame, app: &App, area: Rect, text: &str) {
    let Some(d) = app.selected() else { return };
    let range = detail::target_range(d).map(|r| format!(" [{r}]")).unwrap_or_default();
    let line =
        Line::from(vec![Span::raw(format!("{}{range}: ", d.key.label())), Span::styled(format!("{text}_"), BOLD)]);
    let hint = Line::styled("Enter moves, Esc cancels, space halts all", DIM);
    let w = area.width.saturating_sub(2).max(10);
    let r = Rect { x: area.x + 1, y: area.y + area.height.saturating_sub(5), width: w, height: 4.min(area.height) };
    f.render_widget(Clear, r);
    let block = Block::new().borders(Borders::ALL).title(" Move to ").border_style(YELLOW);
    f.render_widget(Paragraph::new(vec![line, hint]).block(block), r);
}
