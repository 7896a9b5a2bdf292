//! A serial port (or the slave side of a pseudo-terminal) as a [`ByteLink`].
//!
//! `serialport::TTYPort` opens and configures the port (raw mode, baud,
//! character format, exclusive access); reads and writes go straight to the
//! file descriptor through poll(2), so a read returns as soon as any byte
//! arrives rather than after a fixed inter-byte timeout.
//!
//! An open port leaves a [`lock`] file naming this process, so that a
//! second terminal can find who holds it; "device busy" names the holder.

use std::io;
use std::os::fd::{AsRawFd, RawFd};
use std::time::{Duration, Instant};

use serialport::{DataBits, FlowControl, Parity, StopBits, TTYPort};

use super::{lock, ByteLink, LinkError, SerialFormat};

/// An open serial port.
#[derive(Debug)]
pub struct SerialLink {
    /// Declared before `port` so it is removed before the port closes: once
    /// closed, the next holder's lock must not be deleted by us.
    _lock: Option<lock::Lock>,
    port: TTYPort,
    path: String,
}

impl SerialLink {
    /// Opens `path` at `baud` with `format`, no flow control, exclusive.
    pub fn open(path: &str, baud: u32, format: SerialFormat) -> Result<Self, LinkError> {
        let (data_bits, parity) = match format {
            SerialFormat::F8N1 => (DataBits::Eight, Parity::None),
            SerialFormat::F7N1 => (DataBits::Seven, Parity::None),
            SerialFormat::F7E1 => (DataBits::Seven, Parity::Even),
            SerialFormat::F7O1 => (DataBits::Seven, Parity::Odd),
        };
        let builder = serialport::new(path, baud)
            .data_bits(data_bits)
            .parity(parity)
            .stop_bits(StopBits::One)
            .flow_control(FlowControl::None);
        let port =
            TTYPort::open(&builder).map_err(|e| LinkError::Open { path: path.into(), source: os_error(e, path) })?;
        let mut link = Self { _lock: lock::acquire(path), port, path: path.into() };
        // Bytes that arrived before the port was configured may be garbled.
        link.clear_input()?;
        Ok(link)
    }

    pub fn path(&self) -> &str {
        &self.path
    }
}

/// serialport keeps the OS reason only as text: rebuild an io::Error with it.
/// A busy port says who holds it.
fn os_error(e: serialport::Error, path: &str) -> io::Error {
    let kind = match e.kind() {
        serialport::ErrorKind::Io(kind) => kind,
        serialport::ErrorKind::NoDevice => io::ErrorKind::ResourceBusy,
        serialport::ErrorKind::InvalidInput => io::ErrorKind::InvalidInput,
        serialport::ErrorKind::Unknown => io::ErrorKind::Other,
    };
    // serialport keeps nix's text for ENOTTY ("Not a typewriter"), not libc's.
    let not_a_tty = |text: &str| {
        text == "Not a typewriter" || io::Error::from_raw_os_error(libc::ENOTTY).to_string().starts_with(text)
    };
    let text = if e.kind() == serialport::ErrorKind::NoDevice {
        format!("{} (device busy: {})", e.description, lock::describe(path))
    } else if not_a_tty(&e.description) {
        // ENOTTY's own text, "Not a typewriter", names neither the cause nor the fix.
        format!("not a serial port ({}); a link needs a terminal device such as /dev/ttyUSB0, /dev/ttyACM0 or a pty that `axisctl sim` prints", what_it_is(path))
    } else {
        e.description
    };
    io::Error::new(kind, text)
}

/// What a path that is no terminal is, said to people.
fn what_it_is(path: &str) -> &'static str {
    use std::os::unix::fs::FileTypeExt;
    match std::fs::metadata(path).map(|m| m.file_type()) {
        Ok(t) if t.is_file() => "a regular file",
        Ok(t) if t.is_dir() => "a directory",
        Ok(t) if t.is_fifo() => "a pipe",
        Ok(t) if t.is_socket() => "a socket",
        Ok(t) if t.is_char_device() => "a character device without terminal settings",
        _ => "no terminal",
    }
}

impl ByteLink for SerialLink {
    fn write_all(&mut self, bytes: &[u8]) -> Result<(), LinkError> {
        write_all_fd(self.port.as_raw_fd(), bytes, None).map(|_| ())
    }

    fn read(&mut self, buf: &mut [u8], timeout: Duration) -> Result<usize, LinkError> {
        read_fd(self.port.as_raw_fd(), buf, timeout)
    }

    fn clear_input(&mut self) -> Result<(), LinkError> {
        clear_input_fd(self.port.as_raw_fd())
    }
}

/// Maps errors that mean "the other end is gone" to [`LinkError::Closed`].
fn io_error(e: io::Error) -> LinkError {
    match e.raw_os_error() {
        Some(libc::EIO | libc::ENXIO | libc::ENODEV | libc::EPIPE | libc::EBADF) => LinkError::Closed,
        _ => LinkError::Io(e),
    }
}

/// poll(2) on one fd; `Ok(revents)`, 0 on timeout. Retries EINTR within the deadline.
pub(crate) fn poll_fd(fd: RawFd, events: libc::c_short, timeout: Duration) -> Result<libc::c_short, LinkError> {
    let deadline = Instant::now() + timeout;
    loop {
        let mut pfd = libc::pollfd { fd, events, revents: 0 };
        let n = poll_one(&mut pfd, deadline.saturating_duration_since(Instant::now()));
        if n < 0 {
            let e = io::Error::last_os_error();
            if e.kind() == io::ErrorKind::Interrupted {
                continue;
            }
            return Err(io_error(e));
        }
        return Ok(if n == 0 { 0 } else { pfd.revents });
    }
}

/// poll(2) with a timeout to the microsecond where the OS has ppoll: poll's whole
/// milliseconds would turn a 0.2 ms wait (a CAN frame at 1 Mbit/s) into 1 ms.
#[cfg(any(target_os = "linux", target_os = "android", target_os = "freebsd"))]
fn poll_one(pfd: &mut libc::pollfd, timeout: Duration) -> libc::c_int {
    let ts = libc::timespec {
        tv_sec: timeout.as_secs().min(libc::time_t::MAX as u64) as libc::time_t,
        tv_nsec: timeout.subsec_nanos() as _,
    };
    // SAFETY: one valid pollfd, count 1; a valid timespec; no signal mask.
    unsafe { libc::ppoll(pfd, 1, &ts, std::ptr::null()) }
}

#[cfg(not(any(target_os = "linux", target_os = "android", target_os = "freebsd")))]
fn poll_one(pfd: &mut libc::pollfd, timeout: Duration) -> libc::c_int {
    // Round up: a 0.5 ms timeout must not become a busy 0 ms poll.
    let ms = timeout.as_micros().div_ceil(1000).min(i32::MAX as u128) as libc::c_int;
    // SAFETY: one valid pollfd, count 1.
    unsafe { libc::poll(pfd, 1, ms) }
}

/// Reads what is available, waiting up to `timeout` for the first byte.
/// 0 means timeout; end of file and EIO (pty master gone, adapter unplugged) are `Closed`.
pub(crate) fn read_fd(fd: RawFd, buf: &mut [u8], timeout: Duration) -> Result<usize, LinkError> {
    if buf.is_empty() {
        return Ok(0);
    }
    let deadline = Instant::now() + timeout;
    loop {
        let revents = poll_fd(fd, libc::POLLIN, deadline.saturating_duration_since(Instant::now()))?;
        if revents == 0 {
            return Ok(0);
        }
        if revents & libc::POLLNVAL != 0 {
            return Err(LinkError::Closed);
        }
        // POLLIN, POLLHUP or POLLERR: read says which (data, EOF or the error).
        // SAFETY: buf is valid for buf.len() bytes.
        let n = unsafe { libc::read(fd, buf.as_mut_ptr().cast(), buf.len()) };
        match n {
            0 => return Err(LinkError::Closed),
            n if n > 0 => return Ok(n as usize),
            _ => {
                let e = io::Error::last_os_error();
                match e.kind() {
                    io::ErrorKind::Interrupted | io::ErrorKind::WouldBlock => {
                        if Instant::now() >= deadline {
                            return Ok(0);
                        }
                    }
                    _ => return Err(io_error(e)),
                }
            }
        }
    }
}

/// Writes all of `bytes`. With `stall`, gives up once the fd has not accepted a byte
/// for that long and returns how many bytes were written; without, waits as long as it takes.
pub(crate) fn write_all_fd(fd: RawFd, mut bytes: &[u8], stall: Option<Duration>) -> Result<usize, LinkError> {
    let total = bytes.len();
    while !bytes.is_empty() {
        // SAFETY: bytes is valid for bytes.len() bytes.
        let n = unsafe { libc::write(fd, bytes.as_ptr().cast(), bytes.len()) };
        if n > 0 {
            bytes = &bytes[n as usize..];
            continue;
        }
        let e = if n == 0 { io::Error::from(io::ErrorKind::WriteZero) } else { io::Error::last_os_error() };
        match e.kind() {
            io::ErrorKind::Interrupted => {}
            io::ErrorKind::WouldBlock => {
                let wait = stall.unwrap_or(Duration::from_secs(3600));
                let revents = poll_fd(fd, libc::POLLOUT, wait)?;
                if revents == 0 && stall.is_some() {
                    return Ok(total - bytes.len());
                }
                if revents & (libc::POLLHUP | libc::POLLNVAL) != 0 && revents & libc::POLLOUT == 0 {
                    return Err(LinkError::Closed);
                }
            }
            _ => return Err(io_error(e)),
        }
    }
    Ok(total)
}

/// Discards queued input: the kernel's buffer and whatever is already readable.
pub(crate) fn clear_input_fd(fd: RawFd) -> Result<(), LinkError> {
    // SAFETY: plain ioctl on an fd we own.
    if unsafe { libc::tcflush(fd, libc::TCIFLUSH) } != 0 {
        // A pty master may refuse TCIFLUSH on some kernels; draining below still works.
        let e = io::Error::last_os_error();
        if e.raw_os_error() != Some(libc::ENOTTY) && e.raw_os_error() != Some(libc::EINVAL) {
            return Err(io_error(e));
        }
    }
    let mut scratch = [0u8; 512];
    // Bounded, so a device that never stops talking cannot hold us here.
    for _ in 0..64 {
        if read_fd(fd, &mut scratch, Duration::ZERO)? == 0 {
            break;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn open_of_a_missing_path_names_it_and_the_os_reason() {
        let err = SerialLink::open("/dev/axisctl-no-such-tty", 9600, SerialFormat::F8N1).unwrap_err();
        let LinkError::Open { path, source } = &err else { panic!("{err:?}") };
        assert_eq!(path, "/dev/axisctl-no-such-tty");
        assert_eq!(source.kind(), io::ErrorKind::NotFound);
        let text = err.to_string();
        assert!(text.contains("/dev/axisctl-no-such-tty") && text.contains("No such file"), "{text}");
    }

    #[test]
    fn a_busy_port_names_its_holder_and_its_lock_goes_with_it() {
        let (_master, path) = super::super::pty::open_pair().unwrap();
        let held = SerialLink::open(&path, 9600, SerialFormat::F8N1).unwrap();
        let lock_file = lock::lock_path(&lock::canonical(&path)).expect("a lock directory");
        assert!(lock_file.exists());
        let err = SerialLink::open(&path, 9600, SerialFormat::F8N1).unwrap_err();
        let LinkError::Open { source, .. } = &err else { panic!("{err:?}") };
        assert_eq!(source.kind(), io::ErrorKind::ResourceBusy);
        let text = err.to_string();
        // This test program counts as axisctl: it is the process that checks.
        assert!(text.contains(&format!("device busy: held by axisctl, PID {} (", std::process::id())), "{text}");
        drop(held);
        assert!(!lock_file.exists(), "the lock goes with the port");
        drop(SerialLink::open(&path, 9600, SerialFormat::F8N1).expect("free again"));
    }

    #[test]
    fn open_of_a_non_tty_fails_cleanly() {
        let file = tempfile::NamedTempFile::new().unwrap();
        let path = file.path().to_str().unwrap();
        let err = SerialLink::open(path, 9600, SerialFormat::F8N1).unwrap_err();
        assert!(matches!(&err, LinkError::Open { path: p, .. } if p == path), "{err:?}");
        assert!(
            err.to_string().contains("not a serial port (a regular file); a link needs a terminal device"),
            "{err}"
        );
        let err = SerialLink::open("/dev/null", 9600, SerialFormat::F8N1).unwrap_err();
        assert!(err.to_string().contains("not a serial port (a character device without terminal settings)"), "{err}");
    }
}
