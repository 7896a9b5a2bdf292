//! Serving the bench on real links: a pty speaking PowerCube RS232, a pty
//! behaving as an slcan adapter with the bus behind it, or a SocketCAN
//! interface. These loops are the only I/O of the simulators.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Duration;

use super::bench::{lock, Shared};
use super::powercube::PowerCubeBus;
use crate::clock::Clock;
use crate::link::mem::MemCanLink;
use crate::link::{ByteLink, CanLink, LinkError};
use crate::proto::slcan::{AckStyle, Adapter};

/// How long a serving loop blocks before it looks at the bus again.
const TICK: Duration = Duration::from_millis(1);

/// PowerCube RS232 on a byte link: answers as a chain of modules would.
pub fn rs232(
    mut link: Box<dyn ByteLink>,
    bus: Shared<PowerCubeBus>,
    clock: Arc<dyn Clock>,
    stop: &AtomicBool,
) -> Result<(), LinkError> {
    let mut buf = [0u8; 256];
    let mut out = Vec::new();
    while !stop.load(Ordering::Relaxed) {
        let n = link.read(&mut buf, Duration::from_millis(20))?;
        if n == 0 {
            continue;
        }
        lock(&bus).handle_rs232(clock.now(), &buf[..n], &mut out);
        if !out.is_empty() {
            link.write_all(&out)?;
            out.clear();
        }
    }
    Ok(())
}

/// An slcan adapter on a byte link, with `client` as its view of the bus.
pub fn slcan(mut link: Box<dyn ByteLink>, mut client: MemCanLink, stop: &AtomicBool) -> Result<(), LinkError> {
    let mut adapter = Adapter::new(AckStyle::default());
    let mut buf = [0u8; 512];
    while !stop.load(Ordering::Relaxed) {
        let n = link.read(&mut buf, TICK)?;
        adapter.handle_host_bytes(&buf[..n]);
        while let Some(frame) = adapter.poll_transmit() {
            client.send(&frame)?;
        }
        while let Some(frame) = client.recv(Duration::ZERO)? {
            adapter.bus_frame(&frame);
        }
        while let Some(bytes) = adapter.poll_output() {
            link.write_all(&bytes)?;
        }
    }
    Ok(())
}

/// Bridges a real CAN interface and the simulated bus.
pub fn bridge(mut ext: Box<dyn CanLink>, mut client: MemCanLink, stop: &AtomicBool) -> Result<(), LinkError> {
    while !stop.load(Ordering::Relaxed) {
        if let Some(frame) = ext.recv(TICK)? {
            client.send(&frame)?;
        }
        while let Some(frame) = client.recv(Duration::ZERO)? {
            ext.send(&frame)?;
        }
    }
    Ok(())
}
