//! Polling throughput against the wire limit (`scripts/bench.sh` runs it;
//! `cargo bench --bench poll -- LINK SECONDS`).
//!
//! Polls the devices behind LINK back to back for SECONDS, as the
//! dashboard's workers do at their fastest, and meters every frame or byte
//! on the link: the wire is busy for their length at the link's speed, so
//! `busy / elapsed` is the fraction of the physical limit reached.
//! LINK: `slcan:TTY?bitrate=N` (PowerCube modules 3, 5, 17, seven
//! parameters each, pipelined per module), `serial:TTY?baud=N&format=8N1`
//! (the same over RS232) or `serial:TTY?baud=N&format=7N1` (PA-CONTROL
//! axes 1..3, get-actual-pos each). Prints one JSON line.

use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use axisctl::link::{self, ByteLink, CanLink, LinkError, LinkSpec, SerialFormat};
use axisctl::proto::pac::{Command, Par2};
use axisctl::proto::powercube::table::{self, ids};
use axisctl::proto::powercube::{ModuleId, Request};
use axisctl::proto::CanFrame;
use axisctl::session::pac::Pac;
use axisctl::session::powercube::{decode_get, PowerCube};

/// What the dashboard reads of a PowerCube module per poll.
const POLLED: [u8; 7] = [
    ids::ACT_POS,
    ids::ACT_VEL,
    ids::CUR,
    ids::ACT_F_TEMP,
    ids::ACT_F_MOTOR_SUPPLY,
    ids::ACT_F_LOGIC_SUPPLY,
    ids::CUBE_STATE,
];

/// Wire time seen so far, in bit times.
#[derive(Default)]
struct Meter {
    bits: u64,
}

struct MeteredCan(Box<dyn CanLink>, Arc<Mutex<Meter>>);

impl CanLink for MeteredCan {
    fn send(&mut self, frame: &CanFrame) -> Result<(), LinkError> {
        self.1.lock().unwrap().bits += u64::from(frame.wire_bits());
        self.0.send(frame)
    }
    fn send_many(&mut self, frames: &[CanFrame]) -> Result<(), LinkError> {
        self.1.lock().unwrap().bits += frames.iter().map(|f| u64::from(f.wire_bits())).sum::<u64>();
        self.0.send_many(frames)
    }
    fn recv(&mut self, timeout: Duration) -> Result<Option<CanFrame>, LinkError> {
        let f = self.0.recv(timeout)?;
        if let Some(f) = &f {
            self.1.lock().unwrap().bits += u64::from(f.wire_bits());
        }
        Ok(f)
    }
}

struct MeteredBytes(Box<dyn ByteLink>, Arc<Mutex<Meter>>, u64);

impl ByteLink for MeteredBytes {
    fn write_all(&mut self, bytes: &[u8]) -> Result<(), LinkError> {
        self.1.lock().unwrap().bits += bytes.len() as u64 * self.2;
        self.0.write_all(bytes)
    }
    fn read(&mut self, buf: &mut [u8], timeout: Duration) -> Result<usize, LinkError> {
        let n = self.0.read(buf, timeout)?;
        self.1.lock().unwrap().bits += n as u64 * self.2;
        Ok(n)
    }
    fn clear_input(&mut self) -> Result<(), LinkError> {
        self.0.clear_input()
    }
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).filter(|a| a != "--bench").collect();
    let (Some(uri), Some(secs)) = (args.first(), args.get(1).and_then(|s| s.parse::<f64>().ok())) else {
        eprintln!("usage: cargo bench --bench poll -- LINK SECONDS");
        std::process::exit(2);
    };
    let spec: LinkSpec = uri.parse().expect("a link URI");
    let meter = Arc::new(Mutex::new(Meter::default()));
    let run_for = Duration::from_secs_f64(secs);
    let (bit_rate, mut poll): (u32, Box<dyn FnMut() -> u64>) = match &spec {
        LinkSpec::Slcan { bitrate, .. } => {
            let l = link::open_can(&spec).expect("open the CAN link");
            let mut pc = PowerCube::over_can(Box::new(MeteredCan(l, Arc::clone(&meter))));
            (*bitrate, Box::new(move || cube_round(&mut pc)))
        }
        LinkSpec::Serial { path, baud, format } => {
            let baud = baud.unwrap_or(9600);
            let format = format.unwrap_or(SerialFormat::F8N1);
            let l = link::open_bytes(path, baud, format).expect("open the serial link");
            let l = Box::new(MeteredBytes(l, Arc::clone(&meter), format.bits_per_char().into()));
            if format == SerialFormat::F8N1 {
                let mut pc = PowerCube::over_rs232(l, baud);
                (baud, Box::new(move || cube_round(&mut pc)))
            } else {
                let mut pac = Pac::new(l, baud, format);
                (baud, Box::new(move || pac_round(&mut pac)))
            }
        }
        other => panic!("{other}: slcan: or serial: only"),
    };
    poll(); // discovery-like warm-up: the first round opens nothing new, but warms caches
    *meter.lock().unwrap() = Meter::default();
    let start = Instant::now();
    let mut transactions = 0;
    let mut rounds = 0;
    while start.elapsed() < run_for {
        transactions += poll();
        rounds += 1;
    }
    let elapsed = start.elapsed().as_secs_f64();
    let busy = meter.lock().unwrap().bits as f64 / f64::from(bit_rate);
    println!(
        "{}",
        serde_json::json!({
            "link": uri, "seconds": elapsed, "rounds": rounds, "transactions": transactions,
            "per_second": transactions as f64 / elapsed,
            "wire_limit_per_second": transactions as f64 / busy,
            "wire_busy_fraction": busy / elapsed,
        })
    );
}

/// One dashboard round over PowerCube modules 3, 5 and 17: seven reads each.
fn cube_round(pc: &mut PowerCube) -> u64 {
    let mut n = 0;
    for m in [3, 5, 17].map(|m| ModuleId::new(m).unwrap()) {
        let reqs: Vec<_> = POLLED.iter().map(|p| (m, Request::GetExtended { param: *p })).collect();
        for (p, a) in POLLED.iter().zip(pc.transact_many(&reqs).expect("link")) {
            let def = table::param(*p).unwrap();
            decode_get(m, def, &a.expect("an answer")).expect("a value");
            n += 1;
        }
    }
    n
}

/// One round over PA-CONTROL axes 1..3: the actual position of each.
fn pac_round(pac: &mut Pac) -> u64 {
    for axis in 1..=3 {
        pac.transact(&Command::new(0x190C, axis, Par2::Float(0.0))).expect("an answer");
    }
    3
}
