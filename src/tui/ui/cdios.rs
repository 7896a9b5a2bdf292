//! The Cdios pane: a 6168 module's reading, its four status bytes bit by
//! bit, and the goto range a typed target is checked against.

use std::any::Any;

use ratatui::layout::{Constraint, Layout, Rect};
use ratatui::style::{Modifier, Style};
use ratatui::text::{Line, Span};
use ratatui::widgets::{Block, Paragraph};
use ratatui::Frame;

use super::detail::flag_grid;
use super::pane::{changed, same_as, Look, Pane, Units};
use super::{BOLD, DIM, GREEN, RED, YELLOW};
use crate::device::cdios as device;
use crate::device::face::MotionTarget;
use crate::proto::cdios::table::{self as cdios_table, Class};

/// A Cdios 6168 module as last read.
#[derive(Debug, Clone, PartialEq)]
pub struct CdiosSnap {
    pub position: i64,
    pub setpoint: i64,
    pub speed: i64,
    pub rpm_error: i64,
    pub status: [u8; 4],
}

/// The range a Cdios goto position takes (the table's goto field).
pub fn target_range() -> (i64, i64) {
    cdios_table::command("goto")
        .and_then(|c| c.field("position"))
        .map_or((i64::from(i32::MIN), i64::from(i32::MAX)), |f| (f.min, f.max))
}

impl Pane for CdiosSnap {
    fn as_any(&self) -> &dyn Any {
        self
    }

    fn same(&self, other: &dyn Pane) -> bool {
        same_as(self, other)
    }

    fn motion(&self) -> Option<(Units, [f64; 2], Option<f64>)> {
        Some((
            Units { pos: cdios_table::POSITION_UNIT, vel: cdios_table::SPEED_UNIT, cur: None, decimals: 0 },
            [self.position as f64, self.speed as f64],
            None,
        ))
    }

    fn changed_fields(&self, old: &dyn Pane) -> Vec<&'static str> {
        let Some(a) = old.as_any().downcast_ref::<Self>() else { return Vec::new() };
        let status = |s: [u8; 4]| f64::from(u32::from_le_bytes(s));
        changed(&[
            ("pos", a.position as f64, self.position as f64),
            ("setpoint", a.setpoint as f64, self.setpoint as f64),
            ("speed", a.speed as f64, self.speed as f64),
            ("rpm_error", a.rpm_error as f64, self.rpm_error as f64),
            ("status", status(a.status), status(self.status)),
        ])
    }

    fn summary(&self) -> (String, Style) {
        let r = cdios_table::decode_status(self.status);
        if !r.errors.is_empty() {
            ("ERROR".into(), RED.add_modifier(Modifier::BOLD))
        } else if self.status[0] & 0x03 != 0 {
            ("moving".into(), GREEN)
        } else if self.status[2] & 0x80 == 0 {
            ("off".into(), YELLOW)
        } else {
            ("ok".into(), GREEN)
        }
    }

    fn step_unit(&self) -> &'static str {
        cdios_table::POSITION_UNIT
    }

    fn target_range(&self) -> Option<String> {
        let (lo, hi) = target_range();
        Some(format!("{lo} .. {hi} counts"))
    }

    /// A goto position as the CLI checks it: the table's range for the field.
    fn check_target(&self, _at: MotionTarget, target: f64) -> Result<(), String> {
        device::check_position("goto", target).map(|_| ()).map_err(|e| e.to_string())
    }

    fn draw(&self, f: &mut Frame, v: &dyn Look, top: Vec<Line<'static>>, area: Rect) {
        draw(f, v, self, top, area)
    }
}

fn title_again(c: &CdiosSnap, v: &dyn Look) -> Line<'static> {
    Line::styled(
        format!(" Status bytes {:02x} {:02x} {:02x} {:02x} ", c.status[0], c.status[1], c.status[2], c.status[3]),
        v.style("status").add_modifier(Modifier::BOLD),
    )
}

fn draw(f: &mut Frame, v: &dyn Look, c: &CdiosSnap, mut top: Vec<Line<'static>>, area: Rect) {
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
        if !set || v.stale() {
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
