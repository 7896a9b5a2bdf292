//! Transports behind two small traits: [`CanLink`] moves CAN frames,
//! [`ByteLink`] moves bytes. A [`LinkSpec`] is the parsed `--link` URI.

use std::time::Duration;

pub mod log;
pub mod pty;
pub mod serial;
pub mod slcan;
#[cfg(target_os = "linux")]
pub mod socketcan;
pub mod spec;

pub use spec::{LinkSpec, SerialFormat, SpecError};

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
}

/// Moves CAN frames.
pub trait CanLink: Send {
    fn send(&mut self, frame: &CanFrame) -> Result<(), LinkError>;
    /// The next frame, or `None` once `timeout` has passed without one.
    fn recv(&mut self, timeout: Duration) -> Result<Option<CanFrame>, LinkError>;
}

/// Moves bytes (a serial port, a pty).
pub trait ByteLink: Send {
    fn write_all(&mut self, bytes: &[u8]) -> Result<(), LinkError>;
    /// Reads what is available into `buf`; 0 once `timeout` has passed without a byte.
    fn read(&mut self, buf: &mut [u8], timeout: Duration) -> Result<usize, LinkError>;
    /// Drops stale input, before a request on a half-duplex line.
    fn clear_input(&mut self) -> Result<(), LinkError>;
}

impl<T: CanLink + ?Sized> CanLink for Box<T> {
    fn send(&mut self, frame: &CanFrame) -> Result<(), LinkError> {
        (**self).send(frame)
    }
    fn recv(&mut self, timeout: Duration) -> Result<Option<CanFrame>, LinkError> {
        (**self).recv(timeout)
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
