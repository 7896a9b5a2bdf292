//! The PA-CONTROL's line in `sim --trace`: commands and acknowledges cut
//! into frames and decoded.

use axisctl::proto::pac::{self, printable, AckDecoder, CommandDecoder};
use axisctl::sim::serve::Way;

use crate::commands::sim_tap::SerialTrace;

/// One decoder per direction: a frame may come in several chunks.
pub struct PacTrace {
    commands: CommandDecoder,
    acks: AckDecoder,
}

pub fn trace() -> Box<dyn SerialTrace> {
    Box::new(PacTrace { commands: CommandDecoder::new(), acks: AckDecoder::new() })
}

impl SerialTrace for PacTrace {
    fn hear(&mut self, way: Way, bytes: &[u8]) -> Vec<String> {
        if way == Way::FromClient {
            let commands = &mut self.commands;
            commands.push(bytes);
            return std::iter::from_fn(|| commands.next())
                .map(|r| match r {
                    Ok(pac::Request::Command { command, .. }) => {
                        let bytes = command.encode().map(|b| printable(&b)).unwrap_or_default();
                        format!("{bytes}  {command}")
                    }
                    Ok(pac::Request::Poll) => "<EOT>  poll".to_string(),
                    Err(e) => format!("bad frame: {e}"),
                })
                .collect();
        }
        let acks = &mut self.acks;
        acks.push(bytes);
        std::iter::from_fn(|| acks.next())
            .map(|r| match r {
                Ok(ack) => ack.to_string(),
                Err(e) => format!("bad frame: {e}"),
            })
            .collect()
    }
}
