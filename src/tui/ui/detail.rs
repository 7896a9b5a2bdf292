//! The right-hand pane: the selected device in full, as its family's pane
//! draws it ([`super::pane::Pane::draw`]), under the staleness notice.

use crate::address::Address;
use ratatui::layout::Rect;
use ratatui::style::{Modifier, Style};
use ratatui::text::{Line, Span};
use ratatui::widgets::{Block, Paragraph};
use ratatui::Frame;

use super::pane::{Look, Pane};
use super::{BOLD, CHANGED, DIM, YELLOW};
use crate::device::face::MotionTarget;
use crate::tui::app::{App, DeviceView};

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
    snap.draw(f, &v, top, inner);
}

fn title_of(d: &DeviceView) -> String {
    d.snap
        .as_ref()
        .zip(MotionTarget::try_from(d.key).ok())
        .and_then(|(s, at)| s.title(at))
        .unwrap_or_else(|| d.key.label())
}

/// How values are styled: highlighted when just changed, dim when stale.
struct Values<'a> {
    app: &'a App,
    d: &'a DeviceView,
    stale: bool,
}

impl Look for Values<'_> {
    fn style(&self, field: &str) -> Style {
        if self.stale {
            DIM
        } else if self.app.is_fresh_change(self.d, field) {
            CHANGED
        } else {
            Style::new()
        }
    }

    fn stale(&self) -> bool {
        self.stale
    }

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

    fn other(&self, at: MotionTarget) -> Option<(&dyn Pane, Box<dyn Look + '_>)> {
        let d = self.app.device(Address::try_from(at).ok()?)?;
        let look = Values { app: self.app, d, stale: self.app.stale(d).is_some() };
        Some((&**d.snap.as_ref()?, Box::new(look)))
    }
}

/// The unit of a jog step on the selected device (empty where it has none).
pub fn unit_of(d: &DeviceView) -> &'static str {
    d.snap.as_ref().map_or("", |s| s.step_unit())
}

/// The allowed range of a typed target, as the prompt shows it.
pub fn target_range(d: &DeviceView) -> Option<String> {
    d.snap.as_ref()?.target_range()
}

/// Flags in as many columns of `col_w` as fit.
pub(super) fn flag_grid(f: &mut Frame, area: Rect, title: Line<'static>, cells: Vec<(String, Style)>, col_w: u16) {
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
