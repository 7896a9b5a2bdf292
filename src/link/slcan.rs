//! A Lawicel / slcan USB-CAN adapter (CANable, USBtin, CANUSB) as a [`CanLink`].
//!
//! Opening first re-synchronises ([`RESYNC`]: a few CRs end a half line left by a
//! client that died mid-write, and the reply to `V` marks where stale replies
//! end), then runs `C` (its answer is only evidence of the adapter's kind:
//! closing a closed channel is an error on Lawicel adapters), `S<n>`, `O`.
//! Adapters differ in what they acknowledge (see [`crate::proto::slcan`]): one
//! that answers none of them (CANable 1.x firmware) is driven without waiting
//! for acknowledges; one that answers gets its BEL errors checked.
//!
//! Each setup command is followed by `V`, which every firmware answers: the
//! replies before that `V` line are the command's, so an acknowledge is never
//! taken for another command's. Line noise at the open (a stray byte, a BEL
//! that no command caused, a byte glued to a reply) shows as a line that is
//! not a reply, or as more than one reply to a command: the whole handshake
//! is then run again from `C`, up to [`SETUP_ATTEMPTS`] times, and only a
//! clean run's BEL fails the open.

use std::collections::VecDeque;
use std::time::{Duration, Instant};

use super::serial::SerialLink;
use super::{ByteLink, CanLink, LinkError, SerialFormat};
use crate::proto::can_error::CanEvent;
use crate::proto::slcan::{Command, LineDecoder, SlcanEvent, RESYNC};
use crate::proto::CanFrame;

/// How long to wait for the answer to the first command before deciding the
/// adapter never acknowledges. USB adapters answer within a few milliseconds.
pub const PROBE: Duration = Duration::from_millis(100);
/// How long an adapter may take to answer a setup command and the `V` after it.
pub const SETUP_REPLY: Duration = Duration::from_millis(500);
/// How often the handshake runs when line noise garbles it; the last run's
/// replies are taken as they are.
pub const SETUP_ATTEMPTS: u32 = 3;

/// How long the open waits for the adapter's replies ([`PROBE`],
/// [`SETUP_REPLY`]); tests on a loaded machine give their adapter more.
#[derive(Debug, Clone, Copy)]
pub struct SetupTiming {
    pub probe: Duration,
    pub reply: Duration,
}

impl Default for SetupTiming {
    fn default() -> Self {
        Self { probe: PROBE, reply: SETUP_REPLY }
    }
}
/// Serial settings for the tty; USB CDC adapters ignore them.
pub const TTY_BAUD: u32 = 115_200;
/// Transmits awaiting their acknowledge, at most; older ones are forgotten.
const MAX_PENDING: usize = 256;

/// An open slcan adapter on a byte link.
pub struct SlcanLink<B: ByteLink> {
    io: B,
    decoder: LineDecoder,
    bitrate: u32,
    /// The adapter answers commands (it answered `C`).
    acks: bool,
    /// Frames sent whose acknowledge (or BEL) has not arrived yet, oldest first.
    pending: VecDeque<CanFrame>,
    decode_errors: u64,
    adapter_errors: u64,
    /// Transmit lines being written, kept to spare an allocation per frame.
    out: Vec<u8>,
    timing: SetupTiming,
    /// `V` commands written during the setup whose answer has not come yet.
    /// Replies read before those answers belong to earlier commands: a
    /// starved adapter answers later than the setup waits.
    unanswered_v: u32,
    /// The adapter has answered a `V` since this open began.
    answers_v: bool,
}

impl<B: ByteLink> std::fmt::Debug for SlcanLink<B> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SlcanLink").field("bitrate", &self.bitrate).field("acks", &self.acks).finish_non_exhaustive()
    }
}

/// Opens the adapter on tty `path` and starts the channel at `bitrate`.
pub fn open(path: &str, bitrate: u32) -> Result<SlcanLink<SerialLink>, LinkError> {
    open_timed(path, bitrate, SetupTiming::default())
}

/// [`open`] with the setup's waits given.
pub fn open_timed(path: &str, bitrate: u32, timing: SetupTiming) -> Result<SlcanLink<SerialLink>, LinkError> {
    let io = SerialLink::open(path, TTY_BAUD, SerialFormat::F8N1)?;
    SlcanLink::new_timed(io, bitrate, timing).map_err(|e| match e {
        LinkError::Adapter(m) => LinkError::Adapter(format!("{path}: {m}")),
        other => other,
    })
}

impl<B: ByteLink> SlcanLink<B> {
    /// Runs the setup handshake on `io` and opens the CAN channel.
    pub fn new(io: B, bitrate: u32) -> Result<Self, LinkError> {
        Self::new_timed(io, bitrate, SetupTiming::default())
    }

    /// [`SlcanLink::new`] with the setup's waits given.
    pub fn new_timed(io: B, bitrate: u32, timing: SetupTiming) -> Result<Self, LinkError> {
        let set_bitrate = Command::set_bitrate(bitrate).map_err(|e| LinkError::Adapter(e.to_string()))?;
        let mut link = Self {
            io,
            decoder: LineDecoder::new(),
            bitrate,
            acks: false,
            pending: VecDeque::new(),
            decode_errors: 0,
            adapter_errors: 0,
            out: Vec::new(),
            timing,
            unanswered_v: 0,
            answers_v: false,
        };
        link.io.clear_input()?;
        link.handshake(set_bitrate)?;
        Ok(link)
    }

    /// `C`, `S<n>`, `O`, each answered before the `V` sent after it; run
    /// again from a resync while line noise garbles a reply. An adapter
    /// whose `V` answer the resync never saw (noise on that line, or no `V`
    /// at all) is resynced again; on the last attempt the commands are
    /// taken by their first reply, without `V`.
    fn handshake(&mut self, set_bitrate: Command) -> Result<(), LinkError> {
        for attempt in 1..=SETUP_ATTEMPTS {
            let last = attempt == SETUP_ATTEMPTS;
            let errors = self.decode_errors;
            let marked = self.resync()?;
            if !marked && !last {
                continue;
            }
            let close = self.ask(Command::Close, marked, self.timing.probe)?;
            // Without V, an adapter silent to C is not waited for again.
            let wait = if close.answered() { self.timing.reply } else { Duration::ZERO };
            let bitrate = self.ask(set_bitrate, marked, wait)?;
            let open = self.ask(Command::Open, marked, wait)?;
            let noisy = self.decode_errors > errors || [&close, &bitrate, &open].iter().any(|r| r.noisy());
            if noisy && !last {
                continue;
            }
            self.acks = [&close, &bitrate, &open].iter().any(|r| r.answered());
            if self.acks && bitrate.refused() {
                return Err(LinkError::Adapter(format!(
                    "adapter rejected bitrate {} bit/s ({})",
                    self.bitrate,
                    String::from_utf8_lossy(&set_bitrate.to_bytes()).trim_end()
                )));
            }
            if self.acks && open.refused() {
                return Err(LinkError::Adapter(
                    "adapter refused to open the CAN channel (O); is it in use by another program, e.g. slcand?".into(),
                ));
            }
            break;
        }
        Ok(())
    }

    /// Sends a setup command and, with `marked`, `V`, and sorts what comes
    /// back: until the `V` line (at most [`SETUP_REPLY`]), or without
    /// `marked` until the first reply (at most `wait`). Replies before the
    /// answers to earlier `V`s are theirs, not this command's; frames are
    /// stale traffic from before the channel was (re)opened. Both are dropped.
    fn ask(&mut self, cmd: Command, marked: bool, wait: Duration) -> Result<SetupReply, LinkError> {
        let mut bytes = cmd.to_bytes();
        let mut earlier = self.unanswered_v;
        if marked {
            bytes.extend_from_slice(&Command::Version.to_bytes());
            self.unanswered_v += 1;
        }
        self.io.write_all(&bytes)?;
        let deadline = Instant::now() + if marked { self.timing.reply } else { wait };
        let (errors, mut noise, mut own_v) = (self.decode_errors, false, false);
        let mut r = SetupReply::default();
        while let Some(ev) = self.next_event(deadline)? {
            if matches!(&ev, SlcanEvent::Other(line) if line.starts_with('V')) {
                self.unanswered_v = self.unanswered_v.saturating_sub(1);
                if earlier == 0 && marked {
                    own_v = true;
                    break;
                }
                // An earlier command's `V`: what came before it was that command's.
                earlier = earlier.saturating_sub(1);
                r = SetupReply::default();
                continue;
            }
            match ev {
                SlcanEvent::Ack | SlcanEvent::TransmitAck { .. } => r.oks += 1,
                SlcanEvent::Error => {
                    self.adapter_errors += 1;
                    r.bels += 1;
                }
                SlcanEvent::Other(_) => {
                    r.stray += 1;
                    noise = true;
                }
                _ => {}
            }
            if !marked && r.answered() {
                break;
            }
        }
        self.forgive_garbled_v(marked && !own_v, noise || self.decode_errors > errors);
        Ok(r)
    }

    /// A `V` whose answer did not come in time is late, and still counted,
    /// unless the line was noisy meanwhile: then noise garbled its answer,
    /// which will never come.
    fn forgive_garbled_v(&mut self, missing: bool, noisy: bool) {
        if missing && noisy {
            self.unanswered_v = self.unanswered_v.saturating_sub(1);
        }
    }

    pub fn bitrate(&self) -> u32 {
        self.bitrate
    }

    /// Whether the adapter acknowledges commands (Lawicel, CANable 2) or not (CANable 1).
    pub fn adapter_acks(&self) -> bool {
        self.acks
    }

    /// Lines from the adapter that could not be decoded (and were skipped).
    pub fn decode_errors(&self) -> u64 {
        self.decode_errors
    }

    /// BEL replies received since opening.
    pub fn adapter_errors(&self) -> u64 {
        self.adapter_errors
    }

    /// Ends whatever half line the adapter holds and skips every reply up to the
    /// answer to `V`; whether that answer came. Without it, a `C` glued to a
    /// dead client's half line is rejected, the channel stays open and `S<n>`
    /// is refused. An adapter that does not answer `V` costs [`PROBE`], and its
    /// stale replies (if any) are left for the setup, as before.
    ///
    /// A starved adapter answers an earlier resync's `V` while this one
    /// waits: the wait then runs until every `V` is answered, [`SETUP_REPLY`]
    /// after the last answer. `V` answers that never come were garbled by
    /// line noise, and are no longer waited for.
    fn resync(&mut self) -> Result<bool, LinkError> {
        self.io.write_all(RESYNC)?;
        self.unanswered_v += 1;
        let mut deadline = Instant::now() + if self.answers_v { self.timing.reply } else { self.timing.probe };
        let (errors, mut noise, mut answered) = (self.decode_errors, false, false);
        while let Some(ev) = self.next_event(deadline)? {
            match &ev {
                SlcanEvent::Other(line) if line.starts_with('V') => {
                    (answered, self.answers_v) = (true, true);
                    self.unanswered_v = self.unanswered_v.saturating_sub(1);
                    if self.unanswered_v == 0 {
                        break;
                    }
                    deadline = Instant::now() + self.timing.reply;
                }
                SlcanEvent::Other(_) => noise = true,
                _ => {}
            }
        }
        if answered {
            self.unanswered_v = 0;
        }
        self.forgive_garbled_v(!answered, noise || self.decode_errors > errors);
        Ok(answered)
    }

    fn command(&mut self, cmd: Command) -> Result<(), LinkError> {
        self.io.write_all(&cmd.to_bytes())
    }

    /// Reads into the decoder for at most `timeout`; false when nothing came.
    fn fill(&mut self, timeout: Duration) -> Result<bool, LinkError> {
        let mut buf = [0u8; 256];
        let n = self.io.read(&mut buf, timeout)?;
        self.decoder.push(&buf[..n]);
        Ok(n > 0)
    }

    /// The next well-formed event, reading for at most until `deadline`;
    /// malformed lines are counted and skipped.
    fn next_event(&mut self, deadline: Instant) -> Result<Option<SlcanEvent>, LinkError> {
        loop {
            while let Some(ev) = self.decoder.next_event() {
                match ev {
                    Ok(ev) => return Ok(Some(ev)),
                    Err(_) => self.decode_errors += 1,
                }
            }
            let left = deadline.saturating_duration_since(Instant::now());
            if left.is_zero() {
                return Ok(None);
            }
            self.fill(left)?;
        }
    }

    /// Waits for the answer to a setup command: `Some(true)` OK, `Some(false)` BEL,
    /// `None` nothing within `timeout`. Frames still arriving from before the channel
    /// was (re)opened are stale and dropped.
    fn wait_reply(&mut self, timeout: Duration) -> Result<Option<bool>, LinkError> {
        let deadline = Instant::now() + timeout;
        while let Some(ev) = self.next_event(deadline)? {
            match ev {
                SlcanEvent::Ack | SlcanEvent::TransmitAck { .. } => return Ok(Some(true)),
                SlcanEvent::Error => {
                    self.adapter_errors += 1;
                    return Ok(Some(false));
                }
                _ => {}
            }
        }
        Ok(None)
    }
}

/// What came back for one setup command, up to the `V` line after it.
#[derive(Debug, Default)]
struct SetupReply {
    oks: u32,
    bels: u32,
    /// Lines that are no reply: noise, or noise glued to a reply.
    stray: u32,
}

impl SetupReply {
    /// One command has one reply (or none, on a silent adapter): anything
    /// more, or a line that is none, is noise. A missing `V` line alone is
    /// not: an adapter that does not answer `V` is slow to open, not noisy.
    fn noisy(&self) -> bool {
        self.stray > 0 || self.oks + self.bels > 1
    }

    fn answered(&self) -> bool {
        self.oks + self.bels > 0
    }

    /// A BEL and no OK: the adapter said no.
    fn refused(&self) -> bool {
        self.bels > 0 && self.oks == 0
    }
}

impl<B: ByteLink> CanLink for SlcanLink<B> {
    fn send(&mut self, frame: &CanFrame) -> Result<(), LinkError> {
        self.send_many(std::slice::from_ref(frame))
    }

    fn send_many(&mut self, frames: &[CanFrame]) -> Result<(), LinkError> {
        self.out.clear();
        for f in frames {
            Command::Transmit(*f).encode(&mut self.out);
        }
        self.io.write_all(&self.out)?;
        if self.acks {
            for f in frames {
                if self.pending.len() == MAX_PENDING {
                    self.pending.pop_front();
                }
                self.pending.push_back(*f);
            }
        }
        Ok(())
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

    /// Adapters that report errors (`e…`, `s…` lines) always do.
    fn report_errors(&mut self) -> bool {
        true
    }

    fn recv_event(&mut self, timeout: Duration) -> Result<Option<CanEvent>, LinkError> {
        let deadline = Instant::now() + timeout;
        while let Some(ev) = self.next_event(deadline)? {
            match ev {
                SlcanEvent::Frame(f) => return Ok(Some(CanEvent::Frame(f))),
                SlcanEvent::BusError(e) => return Ok(Some(CanEvent::Error(e))),
                SlcanEvent::Ack | SlcanEvent::TransmitAck { .. } => {
                    self.pending.pop_front();
                }
                SlcanEvent::Error => {
                    self.adapter_errors += 1;
                    if let Some(f) = self.pending.pop_front() {
                        return Err(LinkError::Adapter(format!(
                            "adapter did not transmit {f} (BEL): bus off, no other node acknowledging, \
                             or wrong bitrate?"
                        )));
                    }
                }
                // Remote frames, status and version lines: nothing a device command waits for.
                _ => {}
            }
        }
        Ok(None)
    }
}

impl<B: ByteLink> Drop for SlcanLink<B> {
    fn drop(&mut self) {
        // Leave the adapter closed, as slcand does; the link may already be gone.
        let _ = self.command(Command::Close);
        // Wait for the answer: a tty closed with a reply still to come hands
        // that reply to the next program opening it (seen on ptys), which
        // then reads it as the answer to its own first command.
        if self.acks {
            let _ = self.wait_reply(self.timing.probe);
        }
    }
}

#[cfg(test)]
mod tests {
    use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
    use std::sync::{mpsc, Arc};
    use std::thread;

    use super::*;
    use crate::link::pty::{open_pair, PtyMaster};
    use crate::proto::slcan::{AckStyle, Adapter};

    /// A simulated adapter on a pty: every frame the host transmits is answered by
    /// the frames `respond` returns; the host's frames are also sent to `seen`.
    struct Server {
        stop: Arc<AtomicBool>,
        handle: Option<thread::JoinHandle<Adapter>>,
        seen: mpsc::Receiver<CanFrame>,
        path: String,
        /// Bytes the adapter wrote to the host so far, noise included.
        written: Arc<AtomicUsize>,
    }

    /// Line noise: `bytes` written to the host before the adapter's byte
    /// number `at` (counted from 0 over everything it writes).
    #[derive(Clone, Copy)]
    struct Noise {
        at: usize,
        bytes: &'static [u8],
    }

    impl Server {
        fn start(style: AckStyle, respond: fn(&CanFrame) -> Vec<CanFrame>) -> Self {
            Self::start_noisy(style, respond, None)
        }

        fn start_noisy(style: AckStyle, respond: fn(&CanFrame) -> Vec<CanFrame>, noise: Option<Noise>) -> Self {
            let (master, path) = open_pair().unwrap();
            let stop = Arc::new(AtomicBool::new(false));
            let written = Arc::new(AtomicUsize::new(0));
            let (tx, seen) = mpsc::channel();
            let (flag, count) = (stop.clone(), written.clone());
            let handle =
                thread::spawn(move || serve(master, Adapter::new(style), (&flag, &count), &tx, respond, noise));
            Self { stop, handle: Some(handle), seen, path, written }
        }

        fn stop(mut self) -> Adapter {
            self.stop.store(true, Ordering::Relaxed);
            self.handle.take().unwrap().join().unwrap()
        }
    }

    fn serve(
        mut io: PtyMaster,
        mut adapter: Adapter,
        (stop, written): (&AtomicBool, &AtomicUsize),
        seen: &mpsc::Sender<CanFrame>,
        respond: fn(&CanFrame) -> Vec<CanFrame>,
        mut noise: Option<Noise>,
    ) -> Adapter {
        let mut buf = [0u8; 256];
        let mut sent = 0;
        while !stop.load(Ordering::Relaxed) {
            let n = io.read(&mut buf, Duration::from_millis(10)).unwrap();
            adapter.handle_host_bytes(&buf[..n]);
            while let Some(f) = adapter.poll_transmit() {
                let _ = seen.send(f);
                for answer in respond(&f) {
                    adapter.bus_frame(&answer);
                }
            }
            if let Some(mut out) = adapter.poll_output() {
                if let Some(n) = noise.filter(|n| n.at < sent + out.len()) {
                    let i = n.at - sent;
                    out.splice(i..i, n.bytes.iter().copied());
                    noise = None;
                }
                // Counted before the host can read them.
                sent += out.len();
                written.store(sent, Ordering::Relaxed);
                io.write_all(&out).unwrap();
            }
        }
        adapter
    }

    /// A PowerCube-like echo: a frame to 0x0E0 + M is acknowledged on 0x0A0 + M.
    fn ack_on_a0(f: &CanFrame) -> Vec<CanFrame> {
        match f.id() {
            id @ 0x0E0..=0x0FF if !f.is_extended() => vec![CanFrame::new(id - 0x40, f.data()).unwrap()],
            _ => vec![],
        }
    }

    fn exchange_for(style: AckStyle) {
        let server = Server::start(style, ack_on_a0);
        let mut link = open(&server.path, 500_000).unwrap();
        assert_eq!(link.adapter_acks(), style != AckStyle::Silent);
        let home = CanFrame::new(0x0F1, &[0x01]).unwrap();
        let t0 = Instant::now();
        link.send(&home).unwrap();
        assert_eq!(link.recv(Duration::from_secs(2)).unwrap(), Some(CanFrame::new(0x0B1, &[0x01]).unwrap()));
        assert!(t0.elapsed() < Duration::from_millis(500), "round trip took {:?}", t0.elapsed());
        assert_eq!(server.seen.recv_timeout(Duration::from_secs(1)).unwrap(), home);
        let ext = CanFrame::new_extended(0x1234_5678, &[1, 2, 3]).unwrap();
        link.send(&ext).unwrap();
        assert_eq!(server.seen.recv_timeout(Duration::from_secs(1)).unwrap(), ext);
        // Only acknowledges remain: recv times out without a frame.
        let t0 = Instant::now();
        assert_eq!(link.recv(Duration::from_millis(50)).unwrap(), None);
        assert!(t0.elapsed() < Duration::from_millis(400));
        assert_eq!(link.decode_errors(), 0);
        drop(link);
        thread::sleep(Duration::from_millis(50));
        let adapter = server.stop();
        assert_eq!(adapter.bitrate(), 500_000);
        assert!(!adapter.is_open(), "dropping the link closes the channel");
    }

    #[test]
    fn exchanges_frames_with_a_lawicel_adapter() {
        exchange_for(AckStyle::Lawicel);
    }

    #[test]
    fn exchanges_frames_with_a_canable2_adapter() {
        exchange_for(AckStyle::CrOnly);
    }

    #[test]
    fn exchanges_frames_with_a_silent_adapter() {
        exchange_for(AckStyle::Silent);
    }

    /// Line noise from the adapter while the link opens: a stray BEL, a
    /// byte, a byte no line takes, a stray CR, a NUL and BEL, garbage with a
    /// CR. Each lands once at every byte of a clean open's replies (its
    /// resync, and each command's reply and `V`), 30 opens in all; every
    /// open works and the link then exchanges frames.
    /// The test adapter is a thread of this process: on a loaded machine
    /// its replies come later than a USB adapter's, which is no noise.
    const SLOW: SetupTiming = SetupTiming { probe: Duration::from_millis(600), reply: Duration::from_secs(1) };

    #[test]
    fn line_noise_at_the_open_does_not_fail_it() {
        const NOISE: [&[u8]; 6] = [b"\x07", b"x", b"\xff", b"\r", b"\x00\x07", b"#\xfe\r"];
        let clean = Server::start(AckStyle::Lawicel, ack_on_a0);
        let link = open_timed(&clean.path, 500_000, SLOW).unwrap();
        // Every reply of the open has been read once open returns.
        let setup_len = clean.written.load(Ordering::Relaxed);
        assert!(setup_len > 20, "resync, C, S and O each answered: {setup_len} bytes");
        drop(link);
        clean.stop();
        for run in 0..30 {
            let noise = Noise { at: run % setup_len, bytes: NOISE[run % NOISE.len()] };
            let what = format!("run {run}: {:?} before reply byte {}", String::from_utf8_lossy(noise.bytes), noise.at);
            let server = Server::start_noisy(AckStyle::Lawicel, ack_on_a0, Some(noise));
            let mut link = open_timed(&server.path, 500_000, SLOW).unwrap_or_else(|e| panic!("{what}: {e}"));
            assert!(link.adapter_acks(), "{what}");
            assert!(server.written.load(Ordering::Relaxed) >= setup_len + noise.bytes.len(), "{what}: noise sent");
            let home = CanFrame::new(0x0F1, &[0x01]).unwrap();
            link.send(&home).unwrap();
            assert_eq!(
                link.recv(Duration::from_secs(5)).unwrap(),
                Some(CanFrame::new(0x0B1, &[0x01]).unwrap()),
                "{what}"
            );
            drop(link);
            assert_eq!(server.stop().bitrate(), 500_000, "{what}");
        }
    }

    /// Noise scripted into single replies: a BEL no command caused (before
    /// `S`'s OK) and a byte glued to `O`'s OK. Each makes the handshake run
    /// again; a clean run opens.
    #[test]
    fn a_garbled_handshake_runs_again_and_opens() {
        let clean = [&b"V1013\r"[..], b"\rV1013\r", b"\rV1013\r", b"\rV1013\r"];
        for (i, garbled) in [(2, &b"\x07\rV1013\r"[..]), (3, b"x\rV1013\r")] {
            let mut replies: Vec<&'static [u8]> = vec![b"V1013\r", b"\x07V1013\r", b"\rV1013\r", b"\rV1013\r"];
            replies[i] = garbled;
            replies.extend_from_slice(&clean);
            let link = SlcanLink::new(scripted(&replies), 1_000_000).unwrap();
            assert!(link.adapter_acks());
            assert!(link.io.replies.is_empty(), "the handshake ran twice");
        }
        // A BEL alone in a clean run is the adapter's answer, not noise.
        let refusing = [&b"V1013\r"[..], b"\x07V1013\r", b"\rV1013\r", b"\x07V1013\r"];
        let err = SlcanLink::new(scripted(&refusing), 1_000_000).unwrap_err();
        assert!(matches!(&err, LinkError::Adapter(m) if m.contains("open")), "{err}");
    }

    /// An adapter that rejects `V` (BEL) is resynced up to three times, then
    /// set up by the first reply to each command, as without `V` at all.
    #[test]
    fn an_adapter_without_v_opens_by_the_first_replies() {
        let t0 = Instant::now();
        let link = SlcanLink::new(scripted(&[b"\x07", b"\x07", b"\x07", b"\r", b"\r", b"\r"]), 1_000_000).unwrap();
        assert!(link.adapter_acks());
        assert!(link.io.replies.is_empty(), "three resyncs, then C, S8 and O");
        assert!(t0.elapsed() < Duration::from_secs(1), "{:?}", t0.elapsed());
        let err = SlcanLink::new(scripted(&[b"\x07", b"\x07", b"\x07", b"\r", b"\x07"]), 125_000).unwrap_err();
        assert!(matches!(&err, LinkError::Adapter(m) if m.contains("125000")), "{err}");
    }

    #[test]
    fn a_burst_goes_out_in_order_and_every_answer_comes_back() {
        let server = Server::start(AckStyle::Lawicel, ack_on_a0);
        let mut link = open(&server.path, 1_000_000).unwrap();
        let burst: Vec<_> = (0..7u8).map(|i| CanFrame::new(0x0E3, &[0x0A, 0x3C + i]).unwrap()).collect();
        link.send_many(&burst).unwrap();
        for f in &burst {
            assert_eq!(server.seen.recv_timeout(Duration::from_secs(1)).unwrap(), *f);
        }
        for f in &burst {
            assert_eq!(link.recv(Duration::from_secs(2)).unwrap(), Some(CanFrame::new(0x0A3, f.data()).unwrap()));
        }
        assert!(link.pending.is_empty(), "every transmit was acknowledged: {:?}", link.pending);
        drop(link);
        server.stop();
    }

    #[test]
    fn reopening_an_open_adapter_works() {
        let server = Server::start(AckStyle::Lawicel, ack_on_a0);
        // Leave the channel open, as a crashed client would.
        let mut first = SerialLink::open(&server.path, TTY_BAUD, SerialFormat::F8N1).unwrap();
        first.write_all(b"S8\rO\r").unwrap();
        thread::sleep(Duration::from_millis(50));
        drop(first);
        let mut second = open(&server.path, 250_000).unwrap();
        second.send(&CanFrame::new(0x0E3, &[0x00]).unwrap()).unwrap();
        assert_eq!(second.recv(Duration::from_secs(2)).unwrap(), Some(CanFrame::new(0x0A3, &[0x00]).unwrap()));
        drop(second);
        assert_eq!(server.stop().bitrate(), 250_000);
    }

    #[test]
    fn opening_after_a_client_died_mid_line_works_the_first_time() {
        let server = Server::start(AckStyle::Lawicel, ack_on_a0);
        // A crashed client: channel open, then half a transmit line.
        let mut first = SerialLink::open(&server.path, TTY_BAUD, SerialFormat::F8N1).unwrap();
        first.write_all(b"S8\rO\rt0E3").unwrap();
        thread::sleep(Duration::from_millis(50));
        drop(first);
        let mut second = open(&server.path, 250_000).unwrap();
        assert!(second.adapter_acks());
        second.send(&CanFrame::new(0x0E3, &[0x00]).unwrap()).unwrap();
        assert_eq!(second.recv(Duration::from_secs(2)).unwrap(), Some(CanFrame::new(0x0A3, &[0x00]).unwrap()));
        drop(second);
        assert_eq!(server.stop().bitrate(), 250_000);
    }

    /// A byte link that answers the handshake with a script, for adapter misbehaviour.
    struct Scripted {
        replies: VecDeque<&'static [u8]>,
        incoming: Vec<u8>,
    }

    impl ByteLink for Scripted {
        fn write_all(&mut self, bytes: &[u8]) -> Result<(), LinkError> {
            if bytes.ends_with(b"\r") {
                if let Some(r) = self.replies.pop_front() {
                    self.incoming.extend_from_slice(r);
                }
            }
            Ok(())
        }
        fn read(&mut self, buf: &mut [u8], _timeout: Duration) -> Result<usize, LinkError> {
            let n = self.incoming.len().min(buf.len());
            buf[..n].copy_from_slice(&self.incoming[..n]);
            self.incoming.drain(..n);
            Ok(n)
        }
        fn clear_input(&mut self) -> Result<(), LinkError> {
            Ok(())
        }
    }

    fn scripted(replies: &[&'static [u8]]) -> Scripted {
        Scripted { replies: replies.iter().copied().collect(), incoming: Vec::new() }
    }

    #[test]
    fn bel_on_open_is_an_adapter_error() {
        let err = SlcanLink::new(scripted(&[b"V1013\r", b"\x07V1013\r", b"\rV1013\r", b"\x07V1013\r"]), 1_000_000)
            .unwrap_err();
        assert!(matches!(&err, LinkError::Adapter(m) if m.contains("open")), "{err}");
        let err = SlcanLink::new(scripted(&[b"V1013\r", b"\rV1013\r", b"\x07V1013\r"]), 125_000).unwrap_err();
        assert!(matches!(&err, LinkError::Adapter(m) if m.contains("125000") && m.contains("S4")), "{err}");
        assert!(matches!(SlcanLink::new(scripted(&[]), 42), Err(LinkError::Adapter(_))));
    }

    #[test]
    fn stale_frames_during_setup_are_dropped_and_bel_after_transmit_is_reported() {
        let mut link = SlcanLink::new(
            scripted(&[b"\x07\r\x07V1013\r", b"t0B1101\r\x07V1013\r", b"\rV1013\r", b"t0B1102\r\rV1013\r", b"\x07"]),
            1_000_000,
        )
        .unwrap();
        assert!(link.adapter_acks());
        link.send(&CanFrame::new(0x0F1, &[1]).unwrap()).unwrap();
        let err = link.recv(Duration::from_millis(10)).unwrap_err();
        assert!(matches!(&err, LinkError::Adapter(m) if m.contains("0F1#01")), "{err}");
        assert_eq!(link.recv(Duration::from_millis(10)).unwrap(), None);
    }

    /// An adapter whose every reply comes `delay` after the command, as a
    /// pty served by a starved process does. Its replies are real: a closed
    /// channel answers `C` with BEL.
    struct Late {
        adapter: Adapter,
        delay: Duration,
        coming: VecDeque<(Instant, Vec<u8>)>,
    }

    impl ByteLink for Late {
        fn write_all(&mut self, bytes: &[u8]) -> Result<(), LinkError> {
            self.adapter.handle_host_bytes(bytes);
            while let Some(out) = self.adapter.poll_output() {
                self.coming.push_back((Instant::now() + self.delay, out));
            }
            Ok(())
        }
        fn read(&mut self, buf: &mut [u8], timeout: Duration) -> Result<usize, LinkError> {
            let Some(&(at, _)) = self.coming.front() else {
                thread::sleep(timeout);
                return Ok(0);
            };
            let now = Instant::now();
            if at > now + timeout {
                thread::sleep(timeout);
                return Ok(0);
            }
            thread::sleep(at.saturating_duration_since(now));
            let (_, bytes) = self.coming.pop_front().unwrap();
            buf[..bytes.len()].copy_from_slice(&bytes);
            Ok(bytes.len())
        }
        fn clear_input(&mut self) -> Result<(), LinkError> {
            Ok(())
        }
    }

    /// Replies later than the resync waits (the flake "adapter rejected
    /// bitrate (S8)" under load): the answer to the resync's `V` arrives
    /// while the next command waits, so `C`'s BEL used to be read as the
    /// answer to `S8`. Each reply is matched to its own command by counting
    /// the `V` answers still to come, so the open works at every delay.
    #[test]
    fn replies_later_than_the_resync_waits_are_not_taken_for_the_next_commands() {
        for delay_ms in [150, 250] {
            let late = Late {
                adapter: Adapter::new(AckStyle::Lawicel),
                delay: Duration::from_millis(delay_ms),
                coming: VecDeque::new(),
            };
            let link = SlcanLink::new(late, 1_000_000).unwrap_or_else(|e| panic!("{delay_ms} ms: {e}"));
            assert!(link.adapter_acks(), "{delay_ms} ms");
            assert!(link.io.adapter.is_open(), "{delay_ms} ms: the channel is open");
            assert_eq!(link.io.adapter.bitrate(), 1_000_000, "{delay_ms} ms");
        }
    }

    #[test]
    fn garbage_between_frames_is_counted_and_skipped() {
        let mut link =
            SlcanLink::new(scripted(&[b"V1013\r", b"\rV1013\r", b"\rV1013\r", b"\rV1013\r"]), 1_000_000).unwrap();
        link.io.incoming.extend_from_slice(b"t0B\r\xff\xff\rt0B1103\r");
        assert_eq!(link.recv(Duration::from_millis(10)).unwrap(), Some(CanFrame::new(0x0B1, &[3]).unwrap()));
        assert_eq!(link.decode_errors(), 2);
    }

    #[test]
    fn error_reports_reach_a_listener_and_never_a_device_session() {
        let open =
            || SlcanLink::new(scripted(&[b"V1013\r", b"\rV1013\r", b"\rV1013\r", b"\rV1013\r"]), 1_000_000).unwrap();
        let mut link = open();
        link.io.incoming.extend_from_slice(b"e1a\rsb256256\rt0B1103\r");
        assert!(link.report_errors());
        let ms = Duration::from_millis(10);
        let Some(CanEvent::Error(e)) = link.recv_event(ms).unwrap() else { panic!("an error report") };
        assert!(e.problems()[0].starts_with("no acknowledge"), "{:?}", e.problems());
        let Some(CanEvent::Error(e)) = link.recv_event(ms).unwrap() else { panic!("a state change") };
        assert_eq!(e.problems(), ["bus off", "error counters tx 255 rx 255"]);
        assert_eq!(link.recv_event(ms).unwrap(), Some(CanEvent::Frame(CanFrame::new(0x0B1, &[3]).unwrap())));

        let mut link = open();
        link.io.incoming.extend_from_slice(b"e1a\rsb256256\rt0B1103\r");
        assert_eq!(link.recv(ms).unwrap(), Some(CanFrame::new(0x0B1, &[3]).unwrap()), "recv skips them");
        assert_eq!(link.decode_errors(), 0);
    }
}
