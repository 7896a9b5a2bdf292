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

/// The colour the SVG snapshot gives the `index`-th series.
fn colour(index: usize) -> Color {
    let (r, g, b) = crate::plot::colour(index);
    Color::Rgb(r, g, b)
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
    let decimals_of = |t: &Trace| if t.name == "current" { 3 } else { decimals };
    let n = req.traces.len() as u32;
    // Too low for a title in each plot: one line names them all, in their colours.
    let inner = if inner.height / n as u16 >= 4 {
        inner
    } else {
        let mut spans = Vec::new();
        for (i, t) in req.traces.iter().enumerate() {
            let d = decimals_of(t);
            let newest = t.points.last().map_or_else(|| "–".to_string(), |p| format!("{:.d$}", p.1));
            spans.push(Span::styled(format!("{} ", t.name), Style::new().fg(colour(i))));
            spans.push(Span::styled(format!("{newest} {}   ", t.unit), BOLD));
        }
        let [legend, rest] = Layout::vertical([Constraint::Length(1), Constraint::Min(0)]).areas(inner);
        f.render_widget(Paragraph::new(Line::from(spans)), legend);
        rest
    };
    let stacked = inner.height / n as u16 >= X_LABELS_MIN || inner.width / n as u16 <= SIDE_BY_SIDE_MIN;
    let areas = if stacked {
        Layout::vertical((0..n).map(|_| Constraint::Ratio(1, n))).split(inner)
    } else {
        Layout::horizontal((0..n).map(|_| Constraint::Ratio(1, n))).split(inner)
    };
    let label_w = req
        .traces
        .iter()
        .zip(areas.iter())
        .flat_map(|(t, a)| y_labels(t, decimals_of(t), a.height))
        .map(|l| l.chars().count())
        .max()
        .unwrap_or(0);
    for (i, (trace, a)) in req.traces.iter().zip(areas.iter()).enumerate() {
        // Stacked plots share the time axis: only the lowest is labelled.
        let labelled = (!stacked || i + 1 == n as usize) && a.height >= X_LABELS_MIN;
        plot(f, i, trace, *a, decimals_of(trace), labelled, label_w);
    }
}

/// One quantity: its newest value in the axis title, the y range fitted to
/// what is on screen.
/// The y range of a trace: what it holds and a little more; a flat line
/// sits in the middle of a small range around it.
fn fit(points: &[(f64, f64)], decimals: usize) -> (f64, f64) {
    let (mut lo, mut hi) =
        points.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| (lo.min(p.1), hi.max(p.1)));
    if !lo.is_finite() || !hi.is_finite() {
        (lo, hi) = (-1.0, 1.0);
    }
    let least = 10f64.powi(-(decimals as i32));
    let pad = ((hi - lo) * 0.05).max((hi.abs().max(lo.abs()) * 0.05).min(least * 10.0)).max(least);
    (lo - pad, hi + pad)
}

/// The y labels, bottom to top, with the unit on each (stacked plots tell
/// themselves apart by it).
fn y_labels(trace: &Trace, decimals: usize, height: u16) -> Vec<String> {
    let (lo, hi) = fit(&trace.points, decimals);
    let unit = trace.unit;
    let mut out = vec![format!("{lo:.decimals$} {unit}")];
    if height >= 7 {
        out.push(format!("{:.decimals$} {unit}", (lo + hi) / 2.0));
    }
    out.push(format!("{hi:.decimals$} {unit}"));
    out
}

/// One quantity: its newest value in the axis title (when there is room),
/// the y range fitted to the window, labels `label_w` wide so that the time
/// axes of stacked plots line up.
fn plot(f: &mut Frame, index: usize, trace: &Trace, area: Rect, decimals: usize, labelled: bool, label_w: usize) {
    // Thinning keeps each column's extremes: the range is the trace's.
    let columns = usize::from(area.width.saturating_sub(label_w as u16 + 1)).max(1);
    let points = history::thin(&trace.points, columns);
    let newest = points.last().map_or_else(|| "–".to_string(), |p| format!("{:.decimals$}", p.1));
    let style = Style::new().fg(colour(index));
    let (lo, hi) = fit(&trace.points, decimals);
    let labels: Vec<Span> =
        y_labels(trace, decimals, area.height).into_iter().map(|l| Span::raw(format!("{l:>label_w$}"))).collect();
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
                .labels(labels)
                .style(DIM),
        )
        .legend_position(None);
    f.render_widget(chart, area);
}
