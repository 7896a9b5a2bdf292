//! The dashboard's link workers against the wire limit (`scripts/bench.sh`
//! runs it; `cargo bench --bench poll -- LINK SECONDS [FAMILY...]`).
//!
//! Builds the dashboard's worker for LINK with the device sources the
//! dashboard would give it (FAMILY: powercube, cdios, pac; by default
//! powercube and cdios on `slcan:` and `socketcand:` (a bus at 1 Mbit/s),
//! powercube on an 8N1 `serial:`, pac on a 7N1 `serial:`), discovers the devices, then runs polling rounds back to
//! back for SECONDS, as the worker does when the wanted rate is more than
//! the link carries. Every frame or byte on the link is metered: the wire is
//! busy for its length at the link's speed, so `busy / elapsed` is the
//! fraction of the physical limit reached. Prints one JSON line.

use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use axisctl::clock::{Clock, SystemClock};
use axisctl::family::Family;
use axisctl::link::{self, ByteLink, CanLink, LinkError, LinkSpec, SerialFormat};
use axisctl::proto::cdios::NodeId;
use axisctl::proto::CanFrame;
use axisctl::session::bus::CanBus;
use axisctl::session::cdios::Cdios;
use axisctl::session::pac::Pac;
use axisctl::session::powercube::PowerCube;
use axisctl::session::RetryPolicy;
use axisctl::sim::bench::{Bench, WireSpeed};
use axisctl::sim::serve;
use axisctl::tui::cdios::CdiosSource;
use axisctl::tui::event::LinkEvent;
use axisctl::tui::pac::PacSource;
use axisctl::tui::powercube::CubeSource;
use axisctl::tui::source::DeviceSource;
use axisctl::tui::worker::{LinkWorker, MAX_RATE};

/// Wire time seen so far, in bit times, and the frames (or writes) that carried it.
#[derive(Default)]
struct Meter {
    bits: u64,
    received: u64,
}

type SharedMeter = Arc<Mutex<Meter>>;

struct MeteredCan(Box<dyn CanLink>, SharedMeter);

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
            let mut m = self.1.lock().unwrap();
            m.bits += u64::from(f.wire_bits());
            m.received += 1;
        }
        Ok(f)
    }
}

struct MeteredBytes(Box<dyn ByteLink>, SharedMeter, u64);

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

/// The dashboard's CAN sources on one shared link.
fn can_sources(shared: &CanBus, families: Vec<&str>) -> Vec<Box<dyn DeviceSource>> {
    let families = if families.is_empty() { vec!["powercube", "cdios"] } else { families };
    families
        .iter()
        .map(|f| -> Box<dyn DeviceSource> {
            match *f {
                "powercube" => {
                    Box::new(CubeSource::new(PowerCube::over_can(Box::new(shared.port(Family::PowerCube))), None))
                }
                "cdios" => Box::new(CdiosSource::new(
                    Cdios::new(Box::new(shared.port(Family::Cdios))),
                    NodeId::new(1).unwrap(),
                    None,
                    RetryPolicy::default(),
                )),
                other => panic!("{other}: powercube or cdios on CAN"),
            }
        })
        .collect()
}

fn main() {
    let bench_mode = std::env::args().any(|a| a == "--bench");
    let mut args: Vec<String> = std::env::args().skip(1).filter(|a| a != "--bench").collect();
    if !bench_mode && args.is_empty() {
        // `cargo test --all-targets`: one short in-process run, so the harness keeps working.
        args = vec!["sim".into(), "0.1".into()];
    }
    let (Some(uri), Some(secs)) = (args.first(), args.get(1).and_then(|s| s.parse::<f64>().ok())) else {
        eprintln!("usage: cargo bench --bench poll -- LINK SECONDS [FAMILY...]");
        std::process::exit(2);
    };
    if uri == "pty-rtt" {
        return pty_round_trip(secs as usize);
    }
    let families: Vec<&str> = args[2..].iter().map(String::as_str).collect();
    let spec: LinkSpec = uri.parse().expect("a link URI");
    let clock: Arc<dyn Clock> = Arc::new(SystemClock);
    let meter = SharedMeter::default();
    let (bit_rate, sources): (u32, Vec<Box<dyn DeviceSource>>) = match &spec {
        LinkSpec::Slcan { bitrate, .. } => {
            let l = link::open_can(&spec).expect("open the CAN link");
            let shared = CanBus::new(Box::new(MeteredCan(l, Arc::clone(&meter))), Arc::clone(&clock));
            (*bitrate, can_sources(&shared, families))
        }
        LinkSpec::Socketcand { .. } => {
            // The wire is the daemon's bus, which `axisctl sim --wire-speed --socketcand` runs
            // at 1 Mbit/s; the network in between is the overhead measured.
            let l = link::open_can(&spec).expect("open the socketcand link");
            let shared = CanBus::new(Box::new(MeteredCan(l, Arc::clone(&meter))), Arc::clone(&clock));
            (1_000_000, can_sources(&shared, families))
        }
        LinkSpec::Serial { path, baud, format } => {
            let baud = baud.unwrap_or(9600);
            let format = format.unwrap_or(SerialFormat::F8N1);
            let l = link::open_bytes(path, baud, format).expect("open the serial link");
            let l = Box::new(MeteredBytes(l, Arc::clone(&meter), format.bits_per_char().into()));
            let source: Box<dyn DeviceSource> = if format == SerialFormat::F8N1 {
                Box::new(CubeSource::new(PowerCube::over_rs232(l, baud), None))
            } else {
                Box::new(PacSource::new(Pac::new(l, baud, format), None))
            };
            (baud, vec![source])
        }
        LinkSpec::Sim(_) => {
            // The in-process bench at wire speed: the same worker without the pty hops.
            serve::precise_timers();
            let mut bench = Bench::contract(Arc::clone(&clock));
            let wire = WireSpeed::default();
            bench.set_wire_speed(Some(wire));
            if families.first() == Some(&"pac") {
                let bits = SerialFormat::F7N1.bits_per_char();
                let l = Box::new(MeteredBytes(
                    Box::new(bench.pac_link(Arc::clone(&clock))),
                    Arc::clone(&meter),
                    bits.into(),
                ));
                let pac = Pac::new(l, wire.baud, SerialFormat::F7N1).with_clock(Arc::clone(&clock));
                (wire.baud, vec![Box::new(PacSource::new(pac, None)) as Box<dyn DeviceSource>])
            } else {
                let shared = CanBus::new(
                    Box::new(MeteredCan(Box::new(bench.bus.open()), Arc::clone(&meter))),
                    Arc::clone(&clock),
                );
                (wire.bitrate, can_sources(&shared, families))
            }
        }
        other => panic!("{other}: slcan:, socketcand:, serial: or sim only"),
    };
    let mut worker = LinkWorker::new(0, sources, Arc::clone(&clock), MAX_RATE);
    let LinkEvent::Discovered { devices, errors, .. } = worker.discover() else { unreachable!("discover reports") };
    assert!(errors.is_empty() && !devices.is_empty(), "discovery: {devices:?} {errors:?}");
    let mut polls = 0u64;
    let mut failed = 0u64;
    let mut count = |ev: LinkEvent| {
        if let LinkEvent::Polled { result, .. } = ev {
            polls += 1;
            failed += u64::from(result.is_err());
        }
    };
    worker.round(&mut Vec::new, &mut count); // the first round reads what is read once per device
    *meter.lock().unwrap() = Meter::default();
    (polls, failed) = (0, 0);
    let mut count = |ev: LinkEvent| {
        if let LinkEvent::Polled { result, .. } = ev {
            polls += 1;
            failed += u64::from(result.is_err());
        }
    };
    let start = Instant::now();
    let run_for = Duration::from_secs_f64(secs);
    let mut rounds = 0u64;
    while start.elapsed() < run_for {
        worker.round(&mut Vec::new, &mut count);
        rounds += 1;
    }
    let elapsed = start.elapsed().as_secs_f64();
    let m = meter.lock().unwrap();
    let busy = m.bits as f64 / f64::from(bit_rate);
    println!(
        "{}",
        serde_json::json!({
            "link": uri, "devices": devices.len(), "seconds": elapsed, "rounds": rounds,
            "rounds_per_second": rounds as f64 / elapsed, "device_polls": polls, "failed_polls": failed,
            "frames_received_per_second": m.received as f64 / elapsed,
            "wire_busy_fraction": busy / elapsed,
        })
    );
}

/// `pty-rtt N`: N round trips of one slcan line through a pty pair, host to an
/// echoing server thread and back: the turnaround every exchange pays on top
/// of its wire time when the adapter is behind a pty. Prints the median and p90 in µs.
fn pty_round_trip(n: usize) {
    let (mut master, path) = link::pty::open_pair().expect("a pty");
    let stop = Arc::new(std::sync::atomic::AtomicBool::new(false));
    let echo = {
        let stop = Arc::clone(&stop);
        std::thread::spawn(move || {
            serve::precise_timers();
            let mut buf = [0u8; 64];
            while !stop.load(std::sync::atomic::Ordering::Relaxed) {
                let k = master.read(&mut buf, Duration::from_millis(10)).expect("read");
                if k > 0 {
                    master.write_all(&buf[..k]).expect("write");
                }
            }
        })
    };
    let mut host = link::serial::SerialLink::open(&path, 115_200, SerialFormat::F8N1).expect("open the pty");
    let line = b"t0C320A3C\r";
    let mut rtts = Vec::with_capacity(n);
    let mut buf = [0u8; 64];
    for _ in 0..n.max(1) {
        let t0 = Instant::now();
        host.write_all(line).expect("write");
        let mut got = 0;
        while got < line.len() {
            got += host.read(&mut buf, Duration::from_secs(1)).expect("read");
        }
        rtts.push(t0.elapsed().as_secs_f64() * 1e6);
    }
    stop.store(true, std::sync::atomic::Ordering::Relaxed);
    echo.join().unwrap();
    rtts.sort_by(f64::total_cmp);
    let at = |q: f64| rtts[((rtts.len() - 1) as f64 * q) as usize];
    println!("{}", serde_json::json!({"round_trips": rtts.len(), "median_us": at(0.5), "p90_us": at(0.9)}));
}
