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

use axisctl::family::Family;
use axisctl::link::log::{Direction, TrafficLog};
use axisctl::proto::CanFrame;
use axisctl::sim::serve::{Tap, Traffic, Way};

use crate::output::err_line;
use axisctl::monitor::describe;

/// How the bytes of a served link are cut into frames for the trace.
pub enum Protocol {
    Can,
    /// A family's own serial line.
    Serial(Family),
}

/// A family's serial line as the trace says it: the bytes of each way cut
/// into the family's frames (a frame may come in several chunks), one
/// line per frame completed. Each family with a line of its own says it in
/// its folder (`commands/<family>/tap.rs`).
pub trait SerialTrace: Send {
    fn hear(&mut self, way: Way, bytes: &[u8]) -> Vec<String>;
}

enum Decoders {
    Can,
    Serial(Box<dyn SerialTrace>),
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
            Protocol::Serial(family) => {
                super::family_cli(family).serial_trace.map_or(Decoders::Can, |trace| Decoders::Serial(trace()))
            }
            Protocol::Can => Decoders::Can,
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
            (Traffic::Bytes(b), Decoders::Serial(trace)) => trace.hear(way, b),
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

/// Bytes as the trace shows them: `02 06 ...` in lower-case hex.
pub fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect::<Vec<_>>().join(" ")
}
