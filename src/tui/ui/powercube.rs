//! The PowerCube's pane: a module's reading, its CubeState flag by flag
//! (errors red, warnings yellow, information plain), its units and the
//! checks of a typed ramp target.

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
use crate::device::powercube::Move;
use crate::proto::flag_word::FlagClass;
use crate::proto::powercube::flags::{state, CUBE_STATE};
use crate::proto::powercube::limits::Limits;
use crate::proto::powercube::table::{self, ids};

/// A PowerCube module as last read.
#[derive(Debug, Clone, PartialEq)]
pub struct CubeSnap {
    pub linear: bool,
    pub pos: f64,
    pub vel: f64,
    pub cur: f64,
    pub temp: f64,
    pub motor_v: f64,
    pub logic_v: f64,
    pub cube_state: u32,
    pub limits: Limits,
}

impl Pane for CubeSnap {
    fn as_any(&self) -> &dyn Any {
        self
    }

    fn same(&self, other: &dyn Pane) -> bool {
        same_as(self, other)
    }

    fn motion(&self) -> Option<(Units, [f64; 2], Option<f64>)> {
        let unit = |id| table::param(id).map_or("", |d| d.unit_for(self.linear));
        let (pos, vel) = (unit(ids::ACT_POS), unit(ids::ACT_VEL));
        Some((Units { pos, vel, cur: Some("A"), decimals: 4 }, [self.pos, self.vel], Some(self.cur)))
    }

    fn changed_fields(&self, old: &dyn Pane) -> Vec<&'static str> {
        let Some(a) = old.as_any().downcast_ref::<Self>() else { return Vec::new() };
        changed(&[
            ("pos", a.pos, self.pos),
            ("vel", a.vel, self.vel),
            ("cur", a.cur, self.cur),
            ("temp", a.temp, self.temp),
            ("motor_v", a.motor_v, self.motor_v),
            ("logic_v", a.logic_v, self.logic_v),
            ("state", f64::from(a.cube_state), f64::from(self.cube_state)),
        ])
    }

    fn overview_fields(&self) -> [&'static str; 3] {
        ["pos", "vel", "cur"]
    }

    fn summary(&self) -> (String, Style) {
        let s = self.cube_state;
        if CUBE_STATE.decode(s).has_error() {
            ("ERROR".into(), RED.add_modifier(Modifier::BOLD))
        } else if s & state::HALTED != 0 {
            ("halted".into(), YELLOW)
        } else if s & state::MOTION != 0 {
            ("moving".into(), GREEN)
        } else if s & state::HOME_OK == 0 {
            ("unhomed".into(), YELLOW)
        } else {
            ("ok".into(), GREEN)
        }
    }

    fn title(&self, at: MotionTarget) -> Option<String> {
        let MotionTarget::Cube(m) = at else { return None };
        Some(format!("PowerCube module {} ({})", m.get(), if self.linear { "linear" } else { "rotary" }))
    }

    fn step_unit(&self) -> &'static str {
        table::position_unit(self.linear)
    }

    fn target_range(&self) -> Option<String> {
        let l = &self.limits;
        Some(format!("{} .. {} {}", l.min_pos, l.max_pos, table::position_unit(self.linear)))
    }

    /// The CLI's ramp check, against the limits last read.
    fn check_target(&self, at: MotionTarget, target: f64) -> Result<(), String> {
        let MotionTarget::Cube(m) = at else { return Ok(()) };
        Move::check_ramp_target(&self.limits, m, target).map_err(|e| e.to_string())
    }

    fn draw(&self, f: &mut Frame, v: &dyn Look, top: Vec<Line<'static>>, area: Rect) {
        draw(f, v, self, top, area)
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

fn draw(f: &mut Frame, v: &dyn Look, c: &CubeSnap, mut top: Vec<Line<'static>>, area: Rect) {
    let u = table::position_unit(c.linear);
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
            (text, if v.stale() || !set { DIM } else { style })
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
