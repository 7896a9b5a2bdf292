//! Transports behind two small traits: [`CanLink`] moves CAN frames,
//! [`ByteLink`] moves bytes. A [`LinkSpec`] is the parsed `--link` URI.

use std::time::Duration;

pub mod lock;
pub mod log;
pub mod mem;
pub mod pty;
pub mod serial;
pub mod slcan;
#[cfg(target_os = "linux")]
pub mod socketcan;
pub mod socketcand;
pub mod spec;

pub use spec::{LinkSpec, PacStart, SerialFormat, SimStart, SpecError};

use crate::proto::can_error::CanEvent;
use crate::proto::CanFrame;

#[derive(Debug, thiserror::Error)]
pub enum LinkError {
    #[error("cannot open {path}: {source}")]
    Open { path: String, source: std::io::Error },
    #[error("link I/O error: {0}")]
    Io(#[from] std::io::Error),
    #[error("link closed (adapter unplugged?)")]
    Closed,
    #[error("adapter error: {0}")]
    Adapter(String),
    /// The far end of a network link (a socketcand daemon) refused, went
    /// away or spoke another protocol; the text names it.
    #[error("{0}")]
    Remote(String),
}

/// Moves CAN frames.
pub trait CanLink: Send {
    fn send(&mut self, frame: &CanFrame) -> Result<(), LinkError>;
    /// Sends frames in order. Links that can hand them over at once (one
    /// write to an slcan adapter) do, so a pipelined burst leaves together.
    fn send_many(&mut self, frames: &[CanFrame]) -> Result<(), LinkError> {
        frames.iter().try_for_each(|f| self.send(f))
    }
    /// The next frame, or `None` once `timeout` has passed without one.
    fn recv(&mut self, timeout: Duration) -> Result<Option<CanFrame>, LinkError>;
    /// Asks for the bus's error frames too, for a listener (`monitor`);
    /// `false` where the link has no way to report them. Device sessions
    /// never ask: [`recv`](Self::recv) hands them nothing but data frames.
    fn report_errors(&mut self) -> bool {
        false
    }
    /// The next data frame or error frame (once [`report_errors`](Self::report_errors)).
    fn recv_event(&mut self, timeout: Duration) -> Result<Option<CanEvent>, LinkError> {
        Ok(self.recv(timeout)?.map(CanEvent::Frame))
    }
    /// What the link itself adds to the time from a request to its answer
    /// (a network's round trip); the sessions add it to their answer
    /// timeouts. Zero for a local adapter.
    fn round_trip(&self) -> Duration {
        Duration::ZERO
    }
    /// When the bus's own clock stamped the last frame received, since the
    /// Unix epoch, where the link hands it over (a socketcand daemon's
    /// stamp); `None`: the host's clock is as good.
    fn stamp(&self) -> Option<Duration> {
        None
    }
}

/// Moves bytes (a serial port, a pty).
pub trait ByteLink: Send {
    fn write_all(&mut self, bytes: &[u8]) -> Result<(), LinkError>;
    /// Reads what is available into `buf`; 0 once `timeout` has passed without a byte.
    fn read(&mut self, buf: &mut [u8], timeout: Duration) -> Result<usize, LinkError>;
    /// Drops stale input, before a request on a half-duplex line.
    fn clear_input(&mut self) -> Result<(), LinkError>;
}

/// Opens a CAN link. `sim` is built by [`crate::sim`], and `serial:` carries bytes:
/// callers check [`LinkSpec::is_can`] and handle `sim` first; here both are
/// [`LinkError::Open`] with an `InvalidInput` reason.
pub fn open_can(spec: &LinkSpec) -> Result<Box<dyn CanLink>, LinkError> {
    let unsupported = |path: &str, why: &str| LinkError::Open {
        path: path.into(),
        source: std::io::Error::new(std::io::ErrorKind::InvalidInput, why.to_string()),
    };
    match spec {
        #[cfg(target_os = "linux")]
        LinkSpec::SocketCan { iface } => Ok(Box::new(socketcan::SocketCanLink::open(iface)?)),
        #[cfg(not(target_os = "linux"))]
        LinkSpec::SocketCan { iface } => Err(unsupported(iface, "SocketCAN exists only on Linux")),
        LinkSpec::Slcan { path, bitrate } => Ok(Box::new(slcan::open(path, *bitrate)?)),
        LinkSpec::Socketcand { host, port, bus, rtt } => Ok(Box::new(socketcand::open(host, *port, bus, *rtt)?)),
        LinkSpec::Serial { path, .. } => {
            Err(unsupported(path, "a serial: link carries bytes, not CAN frames (use slcan: for a USB-CAN adapter)"))
        }
        LinkSpec::Sim(_) => Err(unsupported("sim", "the simulated bench is opened by the sim module, not as a device")),
    }
}

/// Opens a serial port as a byte link.
pub fn open_bytes(path: &str, baud: u32, format: SerialFormat) -> Result<Box<dyn ByteLink>, LinkError> {
    Ok(Box::new(serial::SerialLink::open(path, baud, format)?))
}

impl<T: CanLink + ?Sized> CanLink for Box<T> {
    fn send(&mut self, frame: &CanFrame) -> Result<(), LinkError> {
        (**self).send(frame)
    }
    fn send_many(&mut self, frames: &[CanFrame]) -> Result<(), LinkError> {
        (**self).send_many(frames)
    }
    fn recv(&mut self, timeout: Duration) -> Result<Option<CanFrame>, LinkError> {
        (**self).recv(timeout)
    }
    fn report_errors(&mut self) -> bool {
        (**self).report_errors()
    }
    fn recv_event(&mut self, timeout: Duration) -> Result<Option<CanEvent>, LinkError> {
        (**self).recv_event(timeout)
    }
    fn round_trip(&self) -> Duration {
        (**self).round_trip()
    }
    fn stamp(&self) -> Option<Duration> {
        (**self).stamp()
    }
}

impl<T: ByteLink + ?Sized> ByteLink for Box<T> {
    fn write_all(&mut self, bytes: &[u8]) -> Result<(), LinkError> {
        (**self).write_all(bytes)
    }
    fn read(&mut self, buf: &mut [u8], timeout: Duration) -> Result<usize, LinkError> {
        (**self).read(buf, timeout)
    }
    fn clear_input(&mut self) -> Result<(), LinkError> {
        (**self).clear_input()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn open_err(uri: &str) -> (String, std::io::ErrorKind) {
        match open_can(&uri.parse().unwrap()) {
            Err(LinkError::Open { path, source }) => (path, source.kind()),
            Err(e) => panic!("{uri}: {e:?}"),
            Ok(_) => panic!("{uri} opened"),
        }
    }

    #[test]
    fn open_can_reports_the_path_that_failed() {
        assert_eq!(open_err("slcan:/dev/axisctl-none").0, "/dev/axisctl-none");
        assert_eq!(open_err("socketcan:axisnocan0").0, "axisnocan0");
        assert_eq!(open_err("serial:/dev/ttyS0"), ("/dev/ttyS0".into(), std::io::ErrorKind::InvalidInput));
        assert_eq!(open_err("sim").1, std::io::ErrorKind::InvalidInput);
        let Err(LinkError::Open { path, .. }) = open_bytes("/dev/axisctl-none", 9600, SerialFormat::F7N1) else {
            panic!("opened a missing tty")
        };
        assert_eq!(path, "/dev/axisctl-none");
    }

    #[test]
    fn open_can_runs_slcan_over_a_pty() {
        use crate::proto::slcan::{AckStyle, Adapter};
        let (mut master, path) = pty::open_pair().unwrap();
        let server = std::thread::spawn(move || {
            let mut adapter = Adapter::new(AckStyle::Lawicel);
            let mut buf = [0u8; 64];
            let deadline = std::time::Instant::now() + Duration::from_secs(2);
            while std::time::Instant::now() < deadline {
                let n = master.read(&mut buf, Duration::from_millis(5)).unwrap();
                adapter.handle_host_bytes(&buf[..n]);
                if let Some(out) = adapter.poll_output() {
                    master.write_all(&out).unwrap();
                }
                if let Some(f) = adapter.poll_transmit() {
                    return (f, adapter.bitrate());
                }
            }
            panic!("no frame transmitted")
        });
        let mut link = open_can(&format!("slcan:{path}?bitrate=125000").parse().unwrap()).unwrap();
        let f = CanFrame::new(0x201, &[0x23, 1, 0, 0x88, 0x13, 0, 0, 0]).unwrap();
        link.send(&f).unwrap();
        assert_eq!(server.join().unwrap(), (f, 125_000));
    }
}
