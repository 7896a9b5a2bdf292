//! What the dashboard shows of one device, asked the same way of every
//! family. A poll's reading ([`crate::tui::source::Snapshot`]) is the
//! family's own values behind [`Pane`], implemented in the family's pane
//! module (`ui::powercube`, `ui::pac`, `ui::cdios`): the list, the
//! overview, the chart, the detail pane and the target prompt ask it and
//! hold no family's code: a new family adds its pane and its source, and
//! the one device address ([`crate::Address`]) a variant.

use std::any::Any;
use std::fmt;

use ratatui::layout::Rect;
use ratatui::style::Style;
use ratatui::text::Line;
use ratatui::Frame;

use crate::device::face::MotionTarget;

/// What a family calls its motion values, and their units.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Units {
    pub pos: &'static str,
    pub vel: &'static str,
    pub cur: Option<&'static str>,
    /// Decimals worth showing of a position / velocity.
    pub decimals: usize,
}

/// How the detail pane styles a device's values, and where a pane finds
/// the other devices of its link. Implemented by the detail pane, so that
/// this module depends on no part of the screen.
pub trait Look {
    /// Highlighted when just changed, dim when stale.
    fn style(&self, field: &str) -> Style;
    /// Whether the values shown are old.
    fn stale(&self) -> bool;
    /// `Label        value unit    extra`, in columns.
    fn line(&self, label: &str, field: &str, value: String, extra: String) -> Line<'static>;
    /// Another device's last reading and its look (the PA-CONTROL axis
    /// pane shows its controller's line).
    fn other(&self, at: MotionTarget) -> Option<(&dyn Pane, Box<dyn Look + '_>)>;
}

/// One device's reading, as each part of the screen asks it.
pub trait Pane: fmt::Debug + Send + Sync + 'static {
    /// The reading itself, for its own family's code (the PA-CONTROL axis
    /// pane reads its controller's line).
    fn as_any(&self) -> &dyn Any;

    /// Whether `other` is the same reading (of the same family).
    fn same(&self, other: &dyn Pane) -> bool;

    /// The motion values (position, velocity), the current where the
    /// family reports one, and their units; `None` for a device that does
    /// not move (the PA-CONTROL controller line).
    fn motion(&self) -> Option<(Units, [f64; 2], Option<f64>)>;

    /// The fields that differ from `old`, an earlier reading of the device.
    fn changed_fields(&self, old: &dyn Pane) -> Vec<&'static str>;

    /// The fields behind the overview's position, velocity and current columns.
    fn overview_fields(&self) -> [&'static str; 3] {
        ["pos", "speed", ""]
    }

    /// A short word for the list: what most needs attention.
    fn summary(&self) -> (String, Style);

    /// The detail pane's title, where the family says more than the
    /// device's label (`None`).
    fn title(&self, _at: MotionTarget) -> Option<String> {
        None
    }

    /// The unit of a jog step (empty where the family gives none).
    fn step_unit(&self) -> &'static str {
        ""
    }

    /// The allowed range of a typed target, as the prompt shows it.
    fn target_range(&self) -> Option<String> {
        None
    }

    /// The family's checks of a typed target against this reading (the
    /// worker checks again against a fresh one before sending).
    fn check_target(&self, _at: MotionTarget, _target: f64) -> Result<(), String> {
        Ok(())
    }

    /// The detail pane below the lines `top` (staleness), in `area`.
    fn draw(&self, f: &mut Frame, v: &dyn Look, top: Vec<Line<'static>>, area: Rect);
}

/// [`Pane::same`] for a reading that compares with `==`.
pub fn same_as<T: PartialEq + 'static>(this: &T, other: &dyn Pane) -> bool {
    other.as_any().downcast_ref::<T>() == Some(this)
}

/// The names of the fields whose values differ (NaN equals NaN: a value
/// the device does not have has not changed).
pub fn changed(fields: &[(&'static str, f64, f64)]) -> Vec<&'static str> {
    fields.iter().filter(|(_, a, b)| a != b && !(a.is_nan() && b.is_nan())).map(|(name, _, _)| *name).collect()
}
