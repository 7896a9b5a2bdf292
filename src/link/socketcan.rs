//! A Linux SocketCAN interface (`can0`, `vcan0`, `slcan0`, ...) as a [`CanLink`].

use std::io;
use std::time::{Duration, Instant};

use socketcan::{CanSocket, EmbeddedFrame, ExtendedId, Id, Socket, SocketOptions, StandardId};

use super::{CanLink, LinkError};
use crate::proto::can_error::{CanEvent, ErrorFrame};
use crate::proto::CanFrame;

/// How long a send retries while the interface's transmit queue is full (ENOBUFS).
pub const SEND_RETRY: Duration = Duration::from_millis(100);

/// A raw CAN socket bound to one interface.
#[derive(Debug)]
pub struct SocketCanLink {
    socket: CanSocket,
    iface: String,
}

impl SocketCanLink {
    /// Opens a raw socket on `iface`. A missing interface, or a kernel without CAN
    /// support, is [`LinkError::Open`] naming the interface and the OS reason.
    pub fn open(iface: &str) -> Result<Self, LinkError> {
        let socket =
            CanSocket::open(iface).map_err(|source| LinkError::Open { path: iface.into(), source: explain(source) })?;
        Ok(Self { socket, iface: iface.into() })
    }

    pub fn iface(&self) -> &str {
        &self.iface
    }
}

/// The OS reasons whose own text ("Address family not supported by
/// protocol", "No such device") names neither the cause nor the fix.
fn explain(e: std::io::Error) -> std::io::Error {
    let why = match e.raw_os_error() {
        Some(libc::EAFNOSUPPORT) => {
            "this kernel has no SocketCAN (load it: modprobe can_raw), or use an slcan adapter (--link slcan:/dev/ttyACM0)"
        }
        Some(libc::ENODEV) => "no such CAN interface (`ip -brief link show type can` lists them)",
        _ => return e,
    };
    std::io::Error::new(e.kind(), format!("{why}: {e}"))
}

/// Our frame as a socketcan data frame.
pub fn to_socketcan(f: &CanFrame) -> socketcan::CanFrame {
    let id: Id = if f.is_extended() {
        ExtendedId::new(f.id()).expect("CanFrame holds a 29-bit id").into()
    } else {
        StandardId::new(f.id() as u16).expect("CanFrame holds an 11-bit id").into()
    };
    socketcan::CanFrame::new(id, f.data()).expect("CanFrame holds at most 8 bytes")
}

/// A socketcan frame as ours; `None` for remote and error frames.
pub fn from_socketcan(f: &socketcan::CanFrame) -> Option<CanFrame> {
    let socketcan::CanFrame::Data(d) = f else { return None };
    match d.id() {
        Id::Standard(id) => CanFrame::new(u32::from(id.as_raw()), d.data()),
        Id::Extended(id) => CanFrame::new_extended(id.as_raw(), d.data()),
    }
}

fn link_error(e: io::Error) -> LinkError {
    match e.raw_os_error() {
        // The interface went away (USB adapter unplugged) or was brought down.
        Some(libc::ENODEV | libc::ENXIO | libc::ENETDOWN) => LinkError::Closed,
        _ => LinkError::Io(e),
    }
}

impl CanLink for SocketCanLink {
    fn send(&mut self, frame: &CanFrame) -> Result<(), LinkError> {
        let f = to_socketcan(frame);
        let deadline = Instant::now() + SEND_RETRY;
        loop {
            match self.socket.write_frame(&f) {
                Ok(()) => return Ok(()),
                Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
                // The qdisc is full: frames drain at bus speed, so wait briefly.
                Err(e) if e.raw_os_error() == Some(libc::ENOBUFS) && Instant::now() < deadline => {
                    std::thread::sleep(Duration::from_millis(1));
                }
                Err(e) => return Err(link_error(e)),
            }
        }
    }

    fn recv(&mut self, timeout: Duration) -> Result<Option<CanFrame>, LinkError> {
        let deadline = Instant::now() + timeout;
        loop {
            match self.recv_event(deadline.saturating_duration_since(Instant::now()))? {
                Some(CanEvent::Frame(f)) => return Ok(Some(f)),
                Some(CanEvent::Error(_)) => {}
                None => return Ok(None),
            }
        }
    }

    fn report_errors(&mut self) -> bool {
        self.socket.set_error_filter_accept_all().is_ok()
    }

    fn recv_event(&mut self, timeout: Duration) -> Result<Option<CanEvent>, LinkError> {
        let deadline = Instant::now() + timeout;
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            match self.socket.read_frame_timeout(left) {
                Ok(socketcan::CanFrame::Error(e)) => {
                    return Ok(Some(CanEvent::Error(ErrorFrame::new(e.error_bits(), e.data()))));
                }
                Ok(f) => {
                    if let Some(f) = from_socketcan(&f) {
                        return Ok(Some(CanEvent::Frame(f)));
                    }
                }
                Err(e) if matches!(e.kind(), io::ErrorKind::TimedOut | io::ErrorKind::WouldBlock) => {
                    return Ok(None);
                }
                Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
                Err(e) => return Err(link_error(e)),
            }
            if left.is_zero() {
                return Ok(None);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn a_missing_interface_is_an_open_error_naming_it() {
        let err = SocketCanLink::open("axisnocan0").unwrap_err();
        let LinkError::Open { path, source } = &err else { panic!("{err:?}") };
        assert_eq!(path, "axisnocan0");
        let text = source.to_string();
        assert!(text.contains("os error"), "the OS reason: {source:?}");
        assert!(text.contains("modprobe can_raw") || text.contains("ip -brief link"), "the fix: {source:?}");
        assert!(err.to_string().starts_with("cannot open axisnocan0: "), "{err}");
    }

    #[test]
    fn an_interface_without_can_support_is_an_open_error() {
        // `lo` exists everywhere; binding a CAN socket to it fails either at socket()
        // (no CAN in this kernel) or at bind() (not a CAN device).
        let err = SocketCanLink::open("lo").unwrap_err();
        assert!(matches!(&err, LinkError::Open { path, .. } if path == "lo"), "{err:?}");
    }

    #[test]
    fn remote_frames_are_not_data() {
        let r = <socketcan::CanFrame as EmbeddedFrame>::new_remote(StandardId::new(0x123).unwrap(), 2).unwrap();
        assert_eq!(from_socketcan(&r), None);
    }

    proptest! {
        #[test]
        fn frame_conversion_round_trips(ext in any::<bool>(), id in any::<u32>(),
                                        data in proptest::collection::vec(any::<u8>(), 0..=8)) {
            let f = if ext { CanFrame::new_extended(id & 0x1FFF_FFFF, &data) } else { CanFrame::new(id & 0x7FF, &data) }
                .unwrap();
            let s = to_socketcan(&f);
            prop_assert_eq!(s.is_extended(), ext);
            prop_assert_eq!(from_socketcan(&s), Some(f));
        }
    }
}
