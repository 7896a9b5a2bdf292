//! `axisctl send` options, as typed.

use clap::Args;

use axisctl::device::supervisor::MotionTarget;
use axisctl::family::Family;
use axisctl::monitor::{describe, motion_of};
use axisctl::proto::can_error::ERR_FLAG;
use axisctl::proto::CanFrame;
use axisctl::Address;

#[derive(Debug, Args)]
pub struct SendArgs {
    /// The frame: CAN `ID#DATA` in hex as cansend takes it (0C3#0A3C), or a PA-CONTROL command `CODE;PAR1;TYP;PAR2` (190C;1;0;0)
    pub frame: String,
    /// Send a frame that starts a motion too. Nothing supervises it: it runs on after send ends
    #[arg(long)]
    pub force: bool,
    /// How long to listen for the answers on CAN, in milliseconds
    #[arg(long, value_name = "MS", default_value_t = 100, value_parser = clap::value_parser!(u64).range(0..=60_000))]
    pub listen: u64,
}

/// What `send` was given.
#[derive(Debug, Clone, PartialEq)]
pub enum Frame {
    Can(CanFrame),
    /// A command on the own line of a family (the PA-CONTROL's
    /// `CODE;PAR1;TYP;PAR2`), checked by that family (`LineCommand`).
    Line(Family, String),
}

/// A family's commands typed on its own (not CAN) line, said in its
/// folder (`cli/<family>/send.rs`, `commands/<family>.rs`).
pub struct LineCommand {
    /// Checks the text; says why it is no command of the family.
    pub check: fn(&str) -> Result<(), String>,
    /// The device a batch or shell halts after it, when it may move one.
    pub moves: fn(&str) -> Option<MotionTarget>,
    /// Shows it, refuses one that may move without `force`, sends it.
    pub send: fn(&crate::commands::Ctx, &str, bool) -> anyhow::Result<()>,
}

impl SendArgs {
    /// The frame, or why it is none (a usage error: nothing is sent).
    pub fn parsed(&self) -> Result<Frame, String> {
        parse(&self.frame)
    }

    /// The device a batch or shell halts after a `send` that may have moved it.
    pub fn starts_motion(&self) -> Option<MotionTarget> {
        match self.parsed().ok()? {
            Frame::Line(family, text) => (line_of(family)?.moves)(&text),
            Frame::Can(f) => {
                motion_of(&f)?;
                let i = describe(&f);
                // A Cdios frame names its node and module, the others their
                // module; one the decoder cannot place halts the PowerCube bus.
                let ids = if i.node.is_some() { (i.node, i.module) } else { (i.module, None) };
                let at = i
                    .family
                    .and_then(|f| Address::of_ids(f, ids.0, ids.1))
                    .and_then(|a| MotionTarget::try_from(a).ok());
                Some(at.unwrap_or(MotionTarget::CubeBus))
            }
        }
    }
}

fn line_of(family: Family) -> Option<&'static LineCommand> {
    crate::commands::family_cli(family).line.as_ref()
}

/// `ID#DATA` (3 hex digits a standard id, 8 an extended one) or
/// `CODE;PAR1;TYP;PAR2` (the PA-CONTROL line between STX and ETX).
pub fn parse(text: &str) -> Result<Frame, String> {
    let text = text.trim();
    if text.contains('#') {
        if text.contains("#R") || text.contains("##") {
            return Err(format!("{text:?}: remote and CAN FD frames cannot be sent"));
        }
        let f: CanFrame = text.parse().map_err(|e| format!("{e} (expected ID#DATA, e.g. 0C3#0A3C)"))?;
        if f.is_extended() && f.id() & ERR_FLAG != 0 {
            return Err(format!("{text:?} is an error frame: only the bus sends those"));
        }
        return Ok(Frame::Can(f));
    }
    // Not CAN: a command on the own line of a family that has one.
    let mut why = None;
    for family in Family::ALL {
        let Some(line) = line_of(family) else { continue };
        match (line.check)(text) {
            Ok(()) => return Ok(Frame::Line(family, text.to_string())),
            Err(e) => {
                why.get_or_insert(e);
            }
        }
    }
    Err(why.unwrap_or_else(|| format!("{text:?} is no CAN frame ID#DATA")))
}

#[cfg(test)]
mod tests {
    use axisctl::proto::cdios::{ModuleId as CdiosModule, NodeId};
    use axisctl::proto::powercube::ModuleId;

    use super::*;

    fn args(frame: &str) -> SendArgs {
        SendArgs { frame: frame.into(), force: false, listen: 100 }
    }

    #[test]
    fn frames_parse_and_bad_ones_say_why() {
        assert_eq!(parse("0C3#0A3C"), Ok(Frame::Can(CanFrame::new(0x0C3, &[0x0A, 0x3C]).unwrap())));
        assert_eq!(parse("190C;1;0;0"), Ok(Frame::Line(Family::Pac, "190C;1;0;0".into())));
        assert_eq!(parse(" 0A8D;1;1;100.5 "), Ok(Frame::Line(Family::Pac, "0A8D;1;1;100.5".into())));
        for bad in [
            "",
            "0E3",
            "0E3#0",
            "800#00",
            "123#R",
            "123##1AA",
            "20000004#00",
            "190C;1;0",
            "19C;1;0;0",
            "190C;x;0;0",
            "190C;1;2;0",
            "0A8D;1;1;inf",
        ] {
            assert!(parse(bad).is_err(), "{bad:?}");
        }
    }

    #[test]
    fn motion_frames_name_the_device_a_batch_halts() {
        assert_eq!(args("0F1#01").starts_motion(), Some(MotionTarget::Cube(ModuleId::new(17).unwrap())), "Home");
        assert_eq!(args("100#0100").starts_motion(), Some(MotionTarget::CubeBus), "the Home broadcast");
        assert_eq!(args("0C3#0A3C").starts_motion(), None, "a read");
        assert_eq!(
            args("0E3#0A3C").starts_motion(),
            Some(MotionTarget::Cube(ModuleId::new(3).unwrap())),
            "undecodable"
        );
        assert_eq!(args("0A94;1;1;100.0").starts_motion(), Some(MotionTarget::PacController));
        let (node, module) = (NodeId::new(7).unwrap(), CdiosModule::new(2).unwrap());
        let goto =
            axisctl::device::cdios::goto_commands(axisctl::proto::cdios::GotoMode::Absolute, 3000, None).unwrap();
        let frame = goto.last().unwrap().frame(node, axisctl::proto::cdios::Address::Module(module)).unwrap();
        let cdios = MotionTarget::Cdios { node, module };
        assert_eq!(args(&frame.to_string()).starts_motion(), Some(cdios), "a Cdios goto: {frame}");
        assert_eq!(args("FFFF;1;0;0").starts_motion(), Some(MotionTarget::PacController), "unknown: may move");
        assert_eq!(args("190C;1;0;0").starts_motion(), None, "a read");
        assert_eq!(args("nonsense").starts_motion(), None, "refused before anything is sent");
    }
}
