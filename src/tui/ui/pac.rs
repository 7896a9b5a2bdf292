//! The PA-CONTROL's panes: the controller line (operating status, error
//! number) and each axis (position, speed, 1910 status, 1921 extended
//! status, the traverse area a typed target is checked against).

use std::any::Any;

use ratatui::layout::{Constraint, Layout, Rect};
use ratatui::style::{Modifier, Style};
use ratatui::text::{Line, Span};
use ratatui::widgets::Paragraph;
use ratatui::Frame;

use super::detail::flag_grid;
use super::pane::{changed, same_as, Look, Pane, Units};
use super::{DIM, GREEN, RED, YELLOW};
use crate::device::face::MotionTarget;
use crate::device::pac::{self, TraverseArea};
use crate::proto::pac::table::{self as pac_table, ExtAxisStatus};

/// The PA-CONTROL controller as last read.
#[derive(Debug, Clone, PartialEq)]
pub struct PacCtrlSnap {
    /// Operating status (manual 6.4), e.g. 31 online.
    pub status: u16,
    /// PA-CONTROL error number; 0 = none.
    pub error: u16,
    pub axes: u8,
}

/// One PA-CONTROL axis as last read.
#[derive(Debug, Clone, PartialEq)]
pub struct PacAxisSnap {
    pub position: f64,
    pub speed: f64,
    /// 1910: 0 in position, 1 moving, 2 stopped, 4 fault, 8 measuring.
    pub status: i64,
    /// 1921: extended status word.
    pub ext_status: u32,
    /// Traverse area (1913 / 1914), when the controller reports it.
    pub min_pos: Option<f64>,
    pub max_pos: Option<f64>,
}

impl Pane for PacCtrlSnap {
    fn as_any(&self) -> &dyn Any {
        self
    }

    fn same(&self, other: &dyn Pane) -> bool {
        same_as(self, other)
    }

    fn motion(&self) -> Option<(Units, [f64; 2], Option<f64>)> {
        None
    }

    fn changed_fields(&self, old: &dyn Pane) -> Vec<&'static str> {
        let Some(a) = old.as_any().downcast_ref::<Self>() else { return Vec::new() };
        changed(&[
            ("status", f64::from(a.status), f64::from(self.status)),
            ("error", f64::from(a.error), f64::from(self.error)),
        ])
    }

    fn summary(&self) -> (String, Style) {
        if self.error != 0 {
            (format!("E{:03}", self.error), RED.add_modifier(Modifier::BOLD))
        } else {
            (status_word(self.status).into(), GREEN)
        }
    }

    fn draw(&self, f: &mut Frame, v: &dyn Look, mut top: Vec<Line<'static>>, area: Rect) {
        top.extend(controller_lines(v, self));
        f.render_widget(Paragraph::new(top), area);
    }
}

impl Pane for PacAxisSnap {
    fn as_any(&self) -> &dyn Any {
        self
    }

    fn same(&self, other: &dyn Pane) -> bool {
        same_as(self, other)
    }

    /// The manual's user units (AE), as `pac-state` reports them.
    fn motion(&self) -> Option<(Units, [f64; 2], Option<f64>)> {
        Some((
            Units { pos: pac_table::POSITION_UNIT, vel: pac_table::SPEED_UNIT, cur: None, decimals: 3 },
            [self.position, self.speed],
            None,
        ))
    }

    fn changed_fields(&self, old: &dyn Pane) -> Vec<&'static str> {
        let Some(a) = old.as_any().downcast_ref::<Self>() else { return Vec::new() };
        changed(&[
            ("pos", a.position, self.position),
            ("speed", a.speed, self.speed),
            ("status", a.status as f64, self.status as f64),
            ("ext", f64::from(a.ext_status), f64::from(self.ext_status)),
        ])
    }

    fn summary(&self) -> (String, Style) {
        let ext = ExtAxisStatus::decode(self.ext_status);
        if self.status == 4 {
            ("fault".into(), RED.add_modifier(Modifier::BOLD))
        } else if !ext.power_pack_ready {
            ("not ready".into(), YELLOW)
        } else if ext.positive_limit_activated || ext.negative_limit_activated {
            ("limit sw".into(), YELLOW)
        } else {
            let name = pac_table::axis_status(self.status.max(0) as u64).map_or("?", |s| s.name);
            (name.into(), if self.status == 1 { GREEN } else { Style::new() })
        }
    }

    fn target_range(&self) -> Option<String> {
        self.min_pos.zip(self.max_pos).map(|(lo, hi)| format!("{lo} .. {hi}"))
    }

    /// A target as `pac-move` checks it, against the traverse area last polled.
    fn check_target(&self, at: MotionTarget, target: f64) -> Result<(), String> {
        let MotionTarget::PacAxis(axis) = at else { return Ok(()) };
        let area = self.min_pos.zip(self.max_pos).map(|(min, max)| TraverseArea { min, max });
        pac::check_target(axis, target, area).map_err(|e| e.to_string())
    }

    fn draw(&self, f: &mut Frame, v: &dyn Look, top: Vec<Line<'static>>, area: Rect) {
        draw_axis(f, v, self, top, area)
    }
}

/// A word for the operating status, for the list.
fn status_word(status: u16) -> &'static str {
    match pac_table::mode_of_status(status) {
        Some(pac_table::Mode::Online) => "online",
        Some(pac_table::Mode::Automatic) => "automatic",
        Some(pac_table::Mode::Manual) => "manual",
        Some(pac_table::Mode::Home) => "home",
        _ => "status?",
    }
}

fn controller_lines(v: &dyn Look, p: &PacCtrlSnap) -> Vec<Line<'static>> {
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

fn draw_axis(f: &mut Frame, v: &dyn Look, a: &PacAxisSnap, mut top: Vec<Line<'static>>, area: Rect) {
    if let Some((ctrl, cv)) = v.other(MotionTarget::PacController) {
        if let Some(p) = ctrl.as_any().downcast_ref::<PacCtrlSnap>() {
            let mut l = controller_lines(&*cv, p);
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
    let dim = |s: Style| if v.stale() { DIM } else { s };
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
