//! The chart (`c`): the selected device's position, velocity and (where it
//! has one) current over the last 30 s, one plot per quantity so that each
//! keeps its own unit on its own axis. Drawn from the App's history, thinned
//! to the pane's width: the cost of a frame does not grow with the poll rate.

use ratatui::layout::{Constraint, Layout, Rect};
use ratatui::style::{Color, Style};
use ratatui::symbols::Marker;
use ratatui::text::{Line, Span};
use ratatui::widgets::{Axis, Block, Chart, Dataset, GraphType, Paragraph};
use ratatui::Frame;

use super::{BOLD, DIM};
use crate::tui::app::App;
use crate::tui::history::{self, Trace};

/// A plot narrower than this puts its quantities one above the other.
const SIDE_BY_SIDE_MIN: u16 = 36;
/// A plot lower than this leaves out the time labels under it.
const X_LABELS_MIN: u16 = 6;

fn colour(name: &str) -> Color {
    match name {
        "position" => Color::Cyan,
        "velocity" => Color::Yellow,
        _ => Color::Magenta,
    }
}

pub fn draw(f: &mut Frame, app: &App, area: Rect) {
    let Some(d) = app.selected() else {
        f.render_widget(Paragraph::new(Line::styled("no device selected", DIM)).block(Block::bordered()), area);
        return;
    };
    let req = app.chart_of(d);
    let title = match &req {
        Some(r) => format!(" Chart · {} · c closes, p saves SVG ", r.title),
        None => format!(" Chart · {} ", d.key.label()),
    };
    let block = Block::bordered().title(Span::styled(title, BOLD));
    let inner = block.inner(area);
    f.render_widget(block, area);
    let Some(req) = req else {
        let why = if d.snap.is_none() { "waiting for the first answer…" } else { "no motion values to chart" };
        f.render_widget(Paragraph::new(Line::styled(why, DIM)), inner);
        return;
    };
    let decimals = d.snap.as_ref().and_then(history::motion).map_or(3, |(u, _, _)| u.decimals);
    let n = req.traces.len() as u32;
    let stacked = inner.height / n as u16 >= X_LABELS_MIN || inner.width / n as u16 <= SIDE_BY_SIDE_MIN;
    let areas = if stacked {
        Layout::vertical((0..n).map(|_| Constraint::Ratio(1, n))).split(inner)
    } else {
        Layout::horizontal((0..n).map(|_| Constraint::Ratio(1, n))).split(inner)
    };
    for (i, (trace, a)) in req.traces.iter().zip(areas.iter()).enumerate() {
        // Stacked plots share the time axis: only the lowest is labelled.
        let labelled = (!stacked || i + 1 == n as usize) && a.height >= X_LABELS_MIN;
        plot(f, trace, *a, if trace.name == "current" { 3 } else { decimals }, labelled);
    }
}

/// One quantity: its newest value in the axis title, the y range fitted to
/// what is on screen.
fn plot(f: &mut Frame, trace: &Trace, area: Rect, decimals: usize, labelled: bool) {
    let columns = usize::from(area.width.saturating_sub(10)).max(1);
    let points = history::thin(&trace.points, columns);
    let newest = points.last().map_or_else(|| "–".to_string(), |p| format!("{:.decimals$}", p.1));
    let style = Style::new().fg(colour(trace.name));
    let (mut lo, mut hi) =
        points.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| (lo.min(p.1), hi.max(p.1)));
    if !lo.is_finite() || !hi.is_finite() {
        (lo, hi) = (-1.0, 1.0);
    }
    // A flat line sits in the middle of a small range around it.
    let least = 10f64.powi(-(decimals as i32));
    let pad = ((hi - lo) * 0.05).max((hi.abs().max(lo.abs()) * 0.05).min(least * 10.0)).max(least);
    let (lo, hi) = (lo - pad, hi + pad);
    let mut y_labels = vec![Span::raw(format!("{lo:.decimals$}"))];
    if area.height >= 7 {
        y_labels.push(Span::raw(format!("{:.decimals$}", (lo + hi) / 2.0)));
    }
    y_labels.push(Span::raw(format!("{hi:.decimals$}")));
    let span = history::WINDOW.as_secs_f64();
    let mut x_axis = Axis::default().bounds([-span, 0.0]).style(DIM);
    if labelled {
        x_axis = x_axis.labels(["-30 s", "-15 s", "now"]);
    }
    let data = vec![Dataset::default().marker(Marker::Braille).graph_type(GraphType::Line).style(style).data(&points)];
    let chart = Chart::new(data)
        .x_axis(x_axis)
        .y_axis(
            Axis::default()
                .title(Line::from(vec![
                    Span::styled(format!("{} ", trace.name), style),
                    Span::styled(format!("{newest} {}", trace.unit), BOLD),
                ]))
                .bounds([lo, hi])
                .labels(y_labels)
                .style(DIM),
        )
        .legend_position(None);
    f.render_widget(chart, area);
}
