//! Pseudo-terminals for the simulator server and for tests: the server keeps
//! the master side (a [`ByteLink`]), a client opens the slave path with a
//! `serial:` or `slcan:` link exactly as it would open a USB adapter.
//!
//! Linux detail: when no process has the slave open, reads on the master fail
//! with EIO. [`PtyMaster`] therefore holds a slave fd of its own for as long as
//! it lives, so clients can come and go. That fd is never read; everything
//! written to the master reaches whichever client has the slave open.

use std::io;
use std::os::fd::{AsRawFd, RawFd};
use std::time::Duration;

use serialport::{SerialPort, TTYPort};

use super::serial::{clear_input_fd, read_fd, write_all_fd};
use super::{ByteLink, LinkError};

/// How long a write to the master may wait for a client to drain the slave's
/// buffer before the rest is dropped, as a UART drops bytes nobody listens to.
pub const WRITE_STALL: Duration = Duration::from_millis(250);

/// The server side of a pseudo-terminal.
#[derive(Debug)]
pub struct PtyMaster {
    master: TTYPort,
    /// Held open so the master never sees EIO between clients; never read.
    slave: TTYPort,
    slave_path: String,
    dropped: u64,
}

/// A new pseudo-terminal: its master, and the slave path a client opens.
pub fn open_pair() -> Result<(PtyMaster, String), LinkError> {
    let open_err =
        |e: serialport::Error| LinkError::Open { path: "/dev/ptmx".into(), source: io::Error::other(e.description) };
    // pair() makes the slave raw and takes neither TIOCEXCL nor a flock on it, so
    // clients can still open it exclusively.
    let (master, slave) = TTYPort::pair().map_err(open_err)?;
    let slave_path = slave.name().ok_or_else(|| LinkError::Open {
        path: "/dev/ptmx".into(),
        source: io::Error::other("pseudo-terminal without a slave name"),
    })?;
    let fd = master.as_raw_fd();
    make_raw(fd).map_err(|e| LinkError::Open { path: slave_path.clone(), source: e })?;
    set_nonblocking(fd).map_err(|e| LinkError::Open { path: slave_path.clone(), source: e })?;
    Ok((PtyMaster { master, slave, slave_path: slave_path.clone(), dropped: 0 }, slave_path))
}

/// The master's own termios: Linux starts it raw, but nothing says every kernel does.
fn make_raw(fd: RawFd) -> io::Result<()> {
    // SAFETY: termios is plain data, filled by tcgetattr before use.
    unsafe {
        let mut t: libc::termios = std::mem::zeroed();
        if libc::tcgetattr(fd, &mut t) != 0 {
            return Err(io::Error::last_os_error());
        }
        libc::cfmakeraw(&mut t);
        if libc::tcsetattr(fd, libc::TCSANOW, &t) != 0 {
            return Err(io::Error::last_os_error());
        }
    }
    Ok(())
}

/// Non-blocking, so a write into a full buffer with no client reading cannot hang the server.
fn set_nonblocking(fd: RawFd) -> io::Result<()> {
    // SAFETY: fcntl on an fd we own.
    unsafe {
        let flags = libc::fcntl(fd, libc::F_GETFL);
        if flags < 0 || libc::fcntl(fd, libc::F_SETFL, flags | libc::O_NONBLOCK) < 0 {
            return Err(io::Error::last_os_error());
        }
    }
    Ok(())
}

impl PtyMaster {
    pub fn slave_path(&self) -> &str {
        &self.slave_path
    }

    /// Clears TIOCEXCL on the slave. A client that opened it exclusively and died
    /// without closing it (SIGKILL) leaves the flag set, because the slave held here
    /// keeps the tty alive; other non-root clients then get EBUSY until this is called.
    pub fn clear_exclusive(&self) -> Result<(), LinkError> {
        // SAFETY: TIOCNXCL takes no argument.
        if unsafe { libc::ioctl(self.slave.as_raw_fd(), libc::TIOCNXCL) } != 0 {
            return Err(LinkError::Io(io::Error::last_os_error()));
        }
        Ok(())
    }

    /// Bytes dropped because no client read them (see [`WRITE_STALL`]).
    pub fn dropped(&self) -> u64 {
        self.dropped
    }
}

impl ByteLink for PtyMaster {
    fn write_all(&mut self, bytes: &[u8]) -> Result<(), LinkError> {
        let written = write_all_fd(self.master.as_raw_fd(), bytes, Some(WRITE_STALL))?;
        self.dropped += (bytes.len() - written) as u64;
        Ok(())
    }

    fn read(&mut self, buf: &mut [u8], timeout: Duration) -> Result<usize, LinkError> {
        read_fd(self.master.as_raw_fd(), buf, timeout)
    }

    fn clear_input(&mut self) -> Result<(), LinkError> {
        clear_input_fd(self.master.as_raw_fd())
    }
}

#[cfg(test)]
mod tests {
    use std::time::Instant;

    use super::*;
    use crate::link::serial::SerialLink;
    use crate::link::SerialFormat;

    /// Reads until `n` bytes arrived or a second passed.
    fn read_n(link: &mut dyn ByteLink, n: usize) -> Vec<u8> {
        let deadline = Instant::now() + Duration::from_secs(1);
        let mut got = Vec::new();
        let mut buf = [0u8; 256];
        while got.len() < n && Instant::now() < deadline {
            let k = link.read(&mut buf, Duration::from_millis(50)).unwrap();
            got.extend_from_slice(&buf[..k]);
        }
        got
    }

    #[test]
    fn bytes_pass_unchanged_both_ways() {
        let (mut master, path) = open_pair().unwrap();
        for format in [SerialFormat::F8N1, SerialFormat::F7N1] {
            let mut client = SerialLink::open(&path, 9600, format).unwrap();
            // CR, LF, ETX (^C), XON, XOFF, DEL, 0xff, EOF (^D), ^Z, NUL: all of which a
            // cooked tty would translate, echo, swallow or turn into a signal.
            let special = [0x0d, 0x0a, 0x03, 0x11, 0x13, 0x7f, 0xff, 0x04, 0x1a, 0x00, 0x0d, 0x0d, 0x0a];
            let all: Vec<u8> = special.iter().copied().chain(0..=255u8).collect();
            master.write_all(&all).unwrap();
            assert_eq!(read_n(&mut client, all.len()), all, "master -> client, {format}");
            client.write_all(&all).unwrap();
            assert_eq!(read_n(&mut master, all.len()), all, "client -> master, {format}");
            // No echo came back to the writer either way.
            let mut buf = [0u8; 16];
            assert_eq!(master.read(&mut buf, Duration::from_millis(20)).unwrap(), 0);
            assert_eq!(client.read(&mut buf, Duration::from_millis(20)).unwrap(), 0);
        }
    }

    #[test]
    fn clients_can_come_and_go() {
        let (mut master, path) = open_pair().unwrap();
        let mut buf = [0u8; 16];
        drop(SerialLink::open(&path, 115_200, SerialFormat::F8N1).unwrap());
        // With the last client gone the master still reads (times out) instead of EIO.
        assert_eq!(master.read(&mut buf, Duration::from_millis(20)).unwrap(), 0);
        let mut again = SerialLink::open(&path, 115_200, SerialFormat::F8N1).unwrap();
        again.write_all(b"hi").unwrap();
        assert_eq!(read_n(&mut master, 2), b"hi");
    }

    #[test]
    fn read_times_out_with_zero() {
        let (_master, path) = open_pair().unwrap();
        let mut client = SerialLink::open(&path, 9600, SerialFormat::F8N1).unwrap();
        let mut buf = [0u8; 16];
        let t0 = Instant::now();
        assert_eq!(client.read(&mut buf, Duration::from_millis(60)).unwrap(), 0);
        let took = t0.elapsed();
        assert!(took >= Duration::from_millis(60) && took < Duration::from_millis(500), "{took:?}");
    }

    #[test]
    fn read_returns_as_soon_as_bytes_arrive() {
        let (mut master, path) = open_pair().unwrap();
        let mut client = SerialLink::open(&path, 9600, SerialFormat::F8N1).unwrap();
        let writer = std::thread::spawn(move || {
            std::thread::sleep(Duration::from_millis(30));
            master.write_all(b"x").unwrap();
            master
        });
        let mut buf = [0u8; 16];
        let t0 = Instant::now();
        assert_eq!(client.read(&mut buf, Duration::from_secs(5)).unwrap(), 1);
        assert!(t0.elapsed() < Duration::from_secs(1), "{:?}", t0.elapsed());
        drop(writer.join().unwrap());
    }

    #[test]
    fn server_going_away_mid_read_is_closed() {
        let (master, path) = open_pair().unwrap();
        let mut client = SerialLink::open(&path, 9600, SerialFormat::F8N1).unwrap();
        let closer = std::thread::spawn(move || {
            std::thread::sleep(Duration::from_millis(50));
            drop(master);
        });
        let mut buf = [0u8; 16];
        let t0 = Instant::now();
        let err = client.read(&mut buf, Duration::from_secs(5)).unwrap_err();
        assert!(matches!(err, LinkError::Closed), "{err:?}");
        assert!(t0.elapsed() < Duration::from_secs(2));
        assert!(matches!(client.write_all(b"x"), Err(LinkError::Closed)));
        closer.join().unwrap();
    }

    #[test]
    fn clear_input_discards_pending_bytes() {
        let (mut master, path) = open_pair().unwrap();
        let mut client = SerialLink::open(&path, 9600, SerialFormat::F8N1).unwrap();
        master.write_all(b"stale").unwrap();
        std::thread::sleep(Duration::from_millis(20));
        client.clear_input().unwrap();
        master.write_all(b"new").unwrap();
        assert_eq!(read_n(&mut client, 3), b"new");
    }

    #[test]
    fn clears_a_stale_exclusive_flag() {
        let (master, path) = open_pair().unwrap();
        let excl = |fd: RawFd| {
            let mut v: libc::c_int = -1;
            // SAFETY: TIOCGEXCL writes one int.
            assert_eq!(unsafe { libc::ioctl(fd, libc::TIOCGEXCL, &mut v) }, 0);
            v
        };
        let client = SerialLink::open(&path, 9600, SerialFormat::F8N1).unwrap();
        assert_eq!(excl(master.slave.as_raw_fd()), 1, "clients open exclusively");
        // A client that dies without its destructor never clears the flag.
        std::mem::forget(client);
        master.clear_exclusive().unwrap();
        assert_eq!(excl(master.slave.as_raw_fd()), 0);
    }

    #[test]
    fn writes_with_nobody_reading_are_dropped_not_hung() {
        let (mut master, _path) = open_pair().unwrap();
        let chunk = [b'x'; 4096];
        let t0 = Instant::now();
        // Far more than the kernel buffers between master and slave (about 64 KiB).
        for _ in 0..64 {
            master.write_all(&chunk).unwrap();
            if master.dropped() > 0 {
                break;
            }
        }
        assert!(master.dropped() > 0);
        assert!(t0.elapsed() < Duration::from_secs(5));
    }
}
