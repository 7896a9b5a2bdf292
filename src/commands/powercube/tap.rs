//! The PowerCube's RS232 line in `sim --trace`: requests and answers cut
//! into frames and decoded.

use axisctl::proto::powercube::bus::describe_ack;
use axisctl::proto::powercube::can::Broadcast;
use axisctl::proto::powercube::rs232::{self, Decoder};
use axisctl::sim::serve::Way;

use crate::commands::sim_tap::{hex, SerialTrace};

/// One decoder per direction: a frame may come in several chunks.
pub struct Rs232Trace {
    requests: Decoder,
    answers: Decoder,
}

pub fn trace() -> Box<dyn SerialTrace> {
    Box::new(Rs232Trace { requests: Decoder::new(), answers: Decoder::new() })
}

impl SerialTrace for Rs232Trace {
    fn hear(&mut self, way: Way, bytes: &[u8]) -> Vec<String> {
        let d = if way == Way::FromClient { &mut self.requests } else { &mut self.answers };
        d.push(bytes);
        std::iter::from_fn(|| d.next_frame()).map(|r| line(way, r)).collect()
    }
}

fn line(way: Way, r: Result<rs232::Rs232Frame, axisctl::proto::DecodeError>) -> String {
    let f = match r {
        Ok(f) => f,
        Err(e) => return format!("bad frame: {e}"),
    };
    let mut bytes = Vec::new();
    f.encode(&mut bytes);
    let what = match way {
        // A broadcast carries `[cmd, param]` (specs README), which is no
        // module command: decoded as one, every broadcast would be "too long".
        Way::FromClient if f.is_broadcast() => Broadcast::decode(f.payload.as_slice()).map(|b| format!("{b} to all")),
        Way::FromClient => f.request().map(|req| format!("{req} to module {}", f.module)),
        Way::ToClient => f.response().map(|resp| format!("{} from module {}", describe_ack(&resp).0, f.module)),
    };
    match what {
        Ok(w) => format!("{} {w}", hex(&bytes)),
        Err(e) => format!("{} undecodable: {e}", hex(&bytes)),
    }
}
