//! `axisctl sim` serving the PA-CONTROL on a pty, spoken to as a client
//! would: a serial link at the announced URI.

use crate::common;

use std::time::{Duration, Instant};

use axisctl::link::serial::SerialLink;
use axisctl::link::{ByteLink, LinkSpec, SerialFormat};
use axisctl::proto::pac::{Ack, AckDecoder, Command, Par2};
use common::Sim;

fn open(uri: &str) -> SerialLink {
    let Ok(LinkSpec::Serial { path, baud, format }) = uri.parse() else { panic!("not a serial link: {uri}") };
    // The PA-CONTROL's defaults (the contract's 9600 7N1) are left out, so
    // the link pastes into a shell unquoted.
    assert_eq!((baud, format), (None, None), "{uri}");
    SerialLink::open(&path, 9600, SerialFormat::F7N1).unwrap()
}

fn transact(link: &mut SerialLink, bytes: &[u8]) -> Ack {
    link.write_all(bytes).unwrap();
    let mut dec = AckDecoder::new();
    let mut buf = [0u8; 128];
    let deadline = Instant::now() + Duration::from_secs(5);
    loop {
        assert!(Instant::now() < deadline, "no acknowledge");
        let n = link.read(&mut buf, Duration::from_millis(50)).unwrap();
        dec.push(&buf[..n]);
        if let Some(ack) = dec.next() {
            return ack.unwrap();
        }
    }
}

// Manual 3.4.3: the start-online frame and its printed acknowledge.
#[test]
fn serves_the_pac_on_a_pty_serial() {
    let sim = Sim::start(&["--pac", "pty-serial", "--axes", "5"], 1);
    assert_eq!(sim.links[0].0, "pac");
    let mut link = open(sim.link("pac"));
    let start = [0x01, 0x02, 0x30, 0x36, 0x30, 0x33, 0x3B, 0x30, 0x3B, 0x30, 0x3B, 0x30, 0x03, 0x31, 0x34, 0x04];
    let ack = transact(&mut link, &start);
    assert_eq!(
        ack.encode().unwrap(),
        [1, 2, 0x30, 0x3B, 0x31, 0x3B, 0x33, 0x31, 0x3B, 0x30, 0x3B, 0x30, 0x3B, 0x30, 3, 0x38, 4]
    );
    // --axes: axis 5 exists, axis 6 does not.
    let ack = transact(&mut link, &Command::new(0x190C, 5, Par2::Float(0.0)).encode().unwrap());
    assert_eq!((ack.quit, ack.q_par), (0, Par2::Float(500.0)));
    let ack = transact(&mut link, &Command::new(0x190C, 6, Par2::Float(0.0)).encode().unwrap());
    assert_eq!(ack.quit, 0x20);
}

#[test]
fn serves_the_pac_by_default() {
    let sim = Sim::start(&[], 3);
    let families: Vec<_> = sim.links.iter().map(|(f, _)| f.as_str()).collect();
    assert!(families.contains(&"powercube") && families.contains(&"pac"), "{families:?}");
    let link = sim.link("pac");
    assert!(link.starts_with("serial:/") && !link.contains(['?', '&']), "{link}");
    let ack = transact(&mut open(link), &Command::new(0x190B, 0, Par2::Int(0)).encode().unwrap());
    assert_eq!((ack.quit, ack.status), (0, 1));
}

#[test]
fn refuses_other_places_and_bad_axes() {
    for args in [&["--pac", "pty-slcan"][..], &["--pac", "socketcan:vcan0"], &["--axes", "0"], &["--axes", "17"]] {
        let run = common::run(&[&["sim"], args].concat());
        assert_eq!(run.code, 2, "{args:?}");
    }
}
