//! `axisctl send` options, as typed.

use clap::Args;

use axisctl::device::supervisor::MotionTarget;
use axisctl::family::Family;
use axisctl::monitor::{describe, motion_of};
use axisctl::proto::can_error::ERR_FLAG;
use axisctl::proto::cdios::{ModuleId as CdiosModule, NodeId};
use axisctl::proto::pac::{table as pac_table, Command, Par2};
use axisctl::proto::powercube::ModuleId;
use axisctl::proto::CanFrame;

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
    Pac(Command),
}

impl SendArgs {
    /// The frame, or why it is none (a usage error: nothing is sent).
    pub fn parsed(&self) -> Result<Frame, String> {
        parse(&self.frame)
    }

    /// The device a batch or shell halts after a `send` that may have moved it.
    pub fn starts_motion(&self) -> Option<MotionTarget> {
        match self.parsed().ok()? {
            // A motion command, or one the table does not know (`send` refuses both without --force).
            Frame::Pac(c) => pac_table::command(c.code).is_none_or(|d| d.motion).then_some(MotionTarget::PacController),
            Frame::Can(f) => {
                motion_of(&f)?;
                let i = describe(&f);
                Some(match (i.family, i.node, i.module) {
                    (Some(Family::Cdios), Some(n), Some(m)) => match (NodeId::new(n), CdiosModule::new(m)) {
                        (Some(node), Some(module)) => MotionTarget::Cdios { node, module },
                        _ => MotionTarget::CubeBus,
                    },
                    (Some(Family::PowerCube), _, Some(m)) => {
                        ModuleId::new(m).map_or(MotionTarget::CubeBus, MotionTarget::Cube)
                    }
                    _ => MotionTarget::CubeBus,
                })
            }
        }
    }
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
    let fields: Vec<&str> = text.split(';').collect();
    let [code, par1, typ, par2] = fields[..] else {
        return Err(format!("{text:?} is neither a CAN frame ID#DATA nor a PA-CONTROL command CODE;PAR1;TYP;PAR2"));
    };
    let code = u16::from_str_radix(code, 16)
        .ok()
        .filter(|_| code.len() == 4)
        .ok_or_else(|| format!("PA-CONTROL code {code:?} is not 4 hex digits"))?;
    let par1: i64 = par1.parse().map_err(|_| format!("PAR_1 {par1:?} is not an integer"))?;
    let par2 = match typ {
        "0" => Par2::Int(par2.parse().map_err(|_| format!("PAR_2 {par2:?} is not an integer (TYP 0)"))?),
        "1" => Par2::Float(
            par2.parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| format!("PAR_2 {par2:?} is not a number (TYP 1)"))?,
        ),
        _ => return Err(format!("TYP {typ:?} is 0 (integer) or 1 (float)")),
    };
    Ok(Frame::Pac(Command::new(code, par1, par2)))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn args(frame: &str) -> SendArgs {
        SendArgs { frame: frame.into(), force: false, listen: 100 }
    }

    #[test]
    fn frames_parse_and_bad_ones_say_why() {
        assert_eq!(parse("0C3#0A3C"), Ok(Frame::Can(CanFrame::new(0x0C3, &[0x0A, 0x3C]).unwrap())));
        assert_eq!(parse("190C;1;0;0"), Ok(Frame::Pac(Command::new(0x190C, 1, Par2::Int(0)))));
        assert_eq!(parse("0A8D;1;1;100.5"), Ok(Frame::Pac(Command::new(0x0A8D, 1, Par2::Float(100.5)))));
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
        assert_eq!(args("FFFF;1;0;0").starts_motion(), Some(MotionTarget::PacController), "unknown: may move");
        assert_eq!(args("190C;1;0;0").starts_motion(), None, "a read");
        assert_eq!(args("nonsense").starts_motion(), None, "refused before anything is sent");
    }
}
