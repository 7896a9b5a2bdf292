//! Which Cdios commands may start a motion, and of which module (see `cli::motion`).

use axisctl::bench::Address;
use axisctl::device::supervisor::MotionTarget;

use super::{CdiosCommand, ModuleTarget};
use crate::cli::motion::Names;

/// The module `--node`/`-m` or `-d` names; `None` when `-d` names no Cdios
/// module (the command then fails before sending).
fn cdios(t: &ModuleTarget, names: Names) -> Option<MotionTarget> {
    let at = match &t.device {
        Some(r) => names(r)?,
        None => Address::cdios(t.node.node, t.module?)?,
    };
    match at {
        Address::Cdios { .. } => MotionTarget::try_from(at).ok(),
        _ => None,
    }
}

impl CdiosCommand {
    pub fn starts_motion(&self, names: Names) -> Option<MotionTarget> {
        match self {
            Self::Goto { target, .. } | Self::Traject { target, .. } | Self::Start { target, .. } => {
                cdios(target, names)
            }
            Self::Identify { .. }
            | Self::Status(_)
            | Self::Position { .. }
            | Self::SetPosition { .. }
            | Self::Stop { .. }
            | Self::Enable { .. }
            | Self::Disable(_)
            | Self::Config { .. }
            | Self::Outputs { .. }
            | Self::Analog { .. }
            | Self::Events { .. }
            | Self::Store { .. }
            | Self::Watch { .. } => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use axisctl::bench::{Address, DeviceRef};
    use axisctl::device::supervisor::MotionTarget;
    use axisctl::proto::cdios::{ModuleId, NodeId};
    use clap::Parser;

    use crate::cli::motion::addresses_only;
    use crate::cli::Cli;

    fn parse(line: &str) -> crate::cli::Command {
        Cli::try_parse_from(std::iter::once("axisctl").chain(line.split_whitespace()))
            .unwrap_or_else(|e| panic!("{line}: {e}"))
            .command
    }

    fn motor(node: u8, module: u8) -> MotionTarget {
        MotionTarget::Cdios { node: NodeId::new(node).unwrap(), module: ModuleId::new(module).unwrap() }
    }

    /// `-d` names the same motor as `--node`/`-m`, through the bench's
    /// names; one that names no Cdios module moves nothing (the line fails
    /// before sending).
    #[test]
    fn a_device_named_with_d_is_the_motor_that_moves() {
        let names = |r: &DeviceRef| match r {
            DeviceRef::Name(n) if n == "gripper" => Address::cdios(1, 0),
            DeviceRef::Name(n) if n == "far" => Address::cdios(3, 7),
            DeviceRef::Name(n) if n == "slide" => Address::pac(Some(2)),
            DeviceRef::Name(n) if n == "shoulder" => Address::powercube(3),
            r => addresses_only(r),
        };
        for (line, target) in [
            ("cdios-goto -m 0 3000", Some(motor(1, 0))),
            ("cdios-goto --node 3 -m 7 3000", Some(motor(3, 7))),
            ("cdios-goto -d gripper 3000", Some(motor(1, 0))),
            ("cdios-goto -d cdios:2/5 3000 --wait", Some(motor(2, 5))),
            ("cdios-traject --device far 1", Some(motor(3, 7))),
            ("cdios-start -d far --option min-speed", Some(motor(3, 7))),
            ("cdios-goto -d slide 3000", None),
            ("cdios-goto -d shoulder 3000", None),
            ("cdios-goto -d nobody 3000", None),
            ("cdios-stop -d gripper", None),
            ("cdios-enable -d gripper", None),
            ("record --node 1 -m 0 position -- cdios-goto -d far 3000", Some(motor(3, 7))),
        ] {
            assert_eq!(parse(line).starts_motion(&names), target, "{line}");
        }
    }

    /// `-d` stands for `--node` and `-m` together: with either it is
    /// refused by the parser, so a line cannot name two motors.
    #[test]
    fn d_conflicts_with_node_and_module() {
        for line in
            ["cdios-goto -d gripper -m 0 3000", "cdios-goto -d gripper --node 2 3000", "cdios-status -d gripper -m 0"]
        {
            let e = Cli::try_parse_from(std::iter::once("axisctl").chain(line.split_whitespace())).unwrap_err();
            assert_eq!(e.kind(), clap::error::ErrorKind::ArgumentConflict, "{line}: {e}");
        }
        for line in ["cdios-goto 3000", "cdios-status"] {
            let e = Cli::try_parse_from(std::iter::once("axisctl").chain(line.split_whitespace())).unwrap_err();
            assert_eq!(e.kind(), clap::error::ErrorKind::MissingRequiredArgument, "{line}: {e}");
        }
    }
}
