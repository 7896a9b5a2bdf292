//! The overview (`v`): every device on every link in one table, with its
//! position, velocity and current in its own units and the state word of
//! the device list. It takes the place of the list and the detail pane, so
//! that the whole bench fits at 80 columns: next to the detail, the list
//! is 24 columns wide, too narrow for three values with units.

use ratatui::layout::{Constraint, Rect};
use ratatui::style::{Modifier, Style};
use ratatui::text::{Line, Span};
use ratatui::widgets::{Block, Cell, Paragraph, Row, Table, TableState};
use ratatui::Frame;

use super::{summary, BOLD, CHANGED, DIM};
use crate::tui::app::{App, DeviceView};
use crate::tui::history;
use crate::tui::source::Snapshot;

/// The fields of [`crate::tui::app::changed_fields`] behind each column.
fn fields(snap: &Snapshot) -> [&'static str; 3] {
    snap.overview_fields()
}

/// `0.0700 rad`, or a dash when the device has no such value.
fn cells(d: &DeviceView) -> [Option<String>; 3] {
    let Some((units, [pos, vel], cur)) = d.snap.as_ref().and_then(history::motion) else {
        return [None, None, None];
    };
    let n = units.decimals;
    [
        Some(format!("{pos:.n$} {}", units.pos)),
        Some(format!("{vel:.n$} {}", units.vel)),
        cur.zip(units.cur).map(|(c, u)| format!("{c:.3} {u}")),
    ]
}

pub fn draw(f: &mut Frame, app: &App, area: Rect) {
    let wide = area.width >= 110;
    let mut header = vec!["", "device", "position", "velocity", "current", "state"];
    if wide {
        header.push("link");
    }
    let rows: Vec<Row> = app
        .devices
        .iter()
        .enumerate()
        .map(|(i, d)| {
            let stale = app.stale(d).is_some();
            let values = cells(d);
            let names = d.snap.as_ref().map_or(["", "", ""], fields);
            let value_style = |field: &str| {
                if stale {
                    DIM
                } else if !field.is_empty() && app.is_fresh_change(d, field) {
                    CHANGED
                } else {
                    Style::new()
                }
            };
            let (word, word_style) = summary(app, d);
            let sel = i == app.selected;
            let mut cells = vec![
                Cell::from(if sel { "▶" } else { " " }),
                Cell::from(Span::styled(
                    d.key.label(),
                    if sel { BOLD.add_modifier(Modifier::REVERSED) } else { Style::new() },
                )),
            ];
            for (value, field) in values.into_iter().zip(names) {
                cells.push(match value {
                    Some(v) => Cell::from(Line::styled(v, value_style(field)).right_aligned()),
                    None => Cell::from(Line::styled("–", DIM).right_aligned()),
                });
            }
            cells.push(Cell::from(Span::styled(word, word_style)));
            if wide {
                cells.push(Cell::from(Span::styled(app.links[d.link].name.clone(), DIM)));
            }
            Row::new(cells)
        })
        .collect();
    let mut widths =
        vec![Constraint::Length(1), Constraint::Length(13), Constraint::Length(15), Constraint::Length(16)];
    widths.extend([Constraint::Length(9), Constraint::Length(12)]);
    if wide {
        widths.push(Constraint::Min(10));
    }
    let title = format!(" Overview · {} device(s) · v for the list ", app.devices.len());
    let block = Block::bordered().title(title);
    if app.devices.is_empty() {
        let waiting = app.links.iter().any(|l| !l.discovered);
        let p = Paragraph::new(Line::styled(if waiting { "scanning…" } else { "no devices" }, DIM)).block(block);
        f.render_widget(p, area);
        return;
    }
    let table = Table::new(rows, widths)
        .header(Row::new(header.into_iter().map(|h| Cell::from(Span::styled(h, BOLD)))))
        .column_spacing(1)
        .block(block);
    // The selected row stays in view when the table is taller than its pane.
    let mut state = TableState::default().with_selected(Some(app.selected));
    f.render_stateful_widget(table, area, &mut state);
}

/// Rows the table needs to show every device: borders, header, devices.
pub fn height(app: &App) -> u16 {
    app.devices.len().max(1) as u16 + 3
}
