//! `axisctl sim --trace` / `--log`: what each served link carries, decoded
//! and logged as a client's own `--trace` and `--log` show its traffic, so
//! someone writing a client sees what it sent and what came back.
//!
//! Directions are the client's: `->` / `tx` is what the client sent, `<-` /
//! `rx` what it got, so the simulator's lines read as the client's do.
//! - Trace: `LINK -> FRAME  DECODED` on stderr, LINK as announced.
//! - Log: CAN frames as `candump -l` lines whose interface names the served
//!   link (`slcan0`, `slcan1`, ...); serial chunks as the client's hex lines
//!   with the served line's name before the direction (`serial0 tx 02 06`).
//!   Which name is which link is said once on stderr.

use axisctl::link::log::{Direction, TrafficLog};
use axisctl::proto::pac::{self, printable, AckDecoder, CommandDecoder};
use axisctl::proto::powercube::can::Broadcast;
use axisctl::proto::powercube::rs232::{self, Decoder};
use axisctl::proto::CanFrame;
use axisctl::sim::serve::{Tap, Traffic, Way};

use crate::output::err_line;
use axisctl::monitor::describe;
use axisctl::proto::powercube::bus::describe_ack;

/// How the bytes of a served serial line are cut into frames for the trace.
pub enum Protocol {
    Can,
    PowerCube,
    Pac,
}

/// One decoder per direction: a frame may come in several chunks.
enum Decoders {
    Can,
    PowerCube { requests: Decoder, answers: Decoder },
    Pac { commands: CommandDecoder, acks: AckDecoder },
}

/// A served link's tap: `None` when neither `--trace` nor `--log` asks.
pub fn tap(link: &str, protocol: Protocol, trace: bool, log: Option<TrafficLog>) -> Tap {
    if !trace && log.is_none() {
        return Tap::default();
    }
    if let Some(l) = &log {
        err_line(format_args!("sim: --log names {link} {}", l.iface()));
    }
    let mut state = State {
        link: link.to_string(),
        trace,
        log,
        decoders: match protocol {
            Protocol::Can => Decoders::Can,
            Protocol::PowerCube => Decoders::PowerCube { requests: Decoder::new(), answers: Decoder::new() },
            Protocol::Pac => Decoders::Pac { commands: CommandDecoder::new(), acks: AckDecoder::new() },
        },
    };
    Tap::new(move |way, traffic| state.hear(way, traffic))
}

struct State {
    link: String,
    trace: bool,
    log: Option<TrafficLog>,
    decoders: Decoders,
}

impl State {
    fn hear(&mut self, way: Way, traffic: Traffic<'_>) {
        self.log(way, traffic);
        if self.trace {
            for line in self.decode(way, traffic) {
                let arrow = match way {
                    Way::FromClient => "->",
                    Way::ToClient => "<-",
                };
                err_line(format_args!("{} {arrow} {line}", self.link));
            }
        }
    }

    /// A log that cannot be written is said once and dropped: the bench
    /// serves on.
    fn log(&mut self, way: Way, traffic: Traffic<'_>) {
        let Some(log) = &self.log else { return };
        let dir = match way {
            Way::FromClient => Direction::Tx,
            Way::ToClient => Direction::Rx,
        };
        let written = match traffic {
            Traffic::Can(f) => log.can_frame(f),
            Traffic::Bytes(b) => log.bytes_on_iface(dir, b),
        };
        if let Err(e) = written {
            err_line(format_args!("sim: --log stopped for {}: {e}", self.link));
            self.log = None;
        }
    }

    /// The trace lines for what was heard: one per frame completed.
    fn decode(&mut self, way: Way, traffic: Traffic<'_>) -> Vec<String> {
        match (traffic, &mut self.decoders) {
            (Traffic::Can(f), _) => vec![can_line(f)],
            (Traffic::Bytes(b), Decoders::PowerCube { requests, answers }) => {
                let d = if way == Way::FromClient { requests } else { answers };
                d.push(b);
                std::iter::from_fn(|| d.next_frame()).map(|r| powercube_line(way, r)).collect()
            }
            (Traffic::Bytes(b), Decoders::Pac { commands, acks }) if way == Way::FromClient => {
                commands.push(b);
                std::iter::from_fn(|| commands.next())
                    .map(|r| match r {
                        Ok(pac::Request::Command { command, .. }) => {
                            let bytes = command.encode().map(|b| printable(&b)).unwrap_or_default();
                            format!("{bytes}  {command}")
                        }
                        Ok(pac::Request::Poll) => "<EOT>  poll".to_string(),
                        Err(e) => format!("bad frame: {e}"),
                    })
                    .collect()
            }
            (Traffic::Bytes(b), Decoders::Pac { acks, .. }) => {
                acks.push(b);
                std::iter::from_fn(|| acks.next())
                    .map(|r| match r {
                        Ok(ack) => ack.to_string(),
                        Err(e) => format!("bad frame: {e}"),
                    })
                    .collect()
            }
            (Traffic::Bytes(b), Decoders::Can) => vec![hex(b)],
        }
    }
}

fn can_line(f: &CanFrame) -> String {
    let info = describe(f);
    let text = match (&info.error, info.summary.is_empty()) {
        (Some(e), _) => format!("undecodable: {e}"),
        (None, true) => info.kind.to_string(),
        (None, false) => info.summary.trim_end().to_string(),
    };
    format!("{f:<22} {text}")
}

fn powercube_line(way: Way, r: Result<rs232::Rs232Frame, axisctl::proto::DecodeError>) -> String {
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

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect::<Vec<_>>().join(" ")
}
