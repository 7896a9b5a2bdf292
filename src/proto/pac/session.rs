//! One PA-CONTROL command / acknowledge transaction, sans-IO.
//!
//! Drive it like this:
//! 1. [`Transaction::new`] (or [`Transaction::with_options`]), then write
//!    [`Transaction::request`] to the line;
//! 2. feed every acknowledge decoded by [`AckDecoder`](super::AckDecoder) to
//!    [`Transaction::handle_ack`];
//! 3. on [`Step::NeedPoll`], wait `after`, write [`POLL`] and go to 2;
//!    on [`Step::Done`] the transaction is over.
//!
//! The caller owns the clock and the overall deadline (a move can take
//! minutes). While the transaction is busy (an acknowledge with BE = 0 came
//! and no BE = 1 yet), the controller accepts only polls: see
//! [`allowed_while_busy`].

use std::time::Duration;

use serde::Serialize;

use super::frame::{Ack, Command, EncodeError, EncodeOptions, Par2, POLL};
use super::table;

/// The controller updates its acknowledge in its action loop (< 10 ms,
/// manual 2.3.4); polling faster than this only loads the line.
pub const DEFAULT_POLL_INTERVAL: Duration = Duration::from_millis(50);

/// What to do after an acknowledge.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(tag = "step", rename_all = "kebab-case")]
pub enum Step {
    /// BE = 1: finished.
    Done(Ack),
    /// BE = 0: still processing. Send [`POLL`] after `after` for a fresh
    /// acknowledge; `last` carries the progress (e.g. the current position
    /// of a 0A87 move).
    NeedPoll {
        last: Ack,
        #[serde(with = "millis")]
        after: Duration,
    },
}

mod millis {
    pub fn serialize<S: serde::Serializer>(d: &std::time::Duration, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_u64(d.as_millis() as u64)
    }
}

/// The controller refused the command: QUIT != 0 (manual 6.5).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, thiserror::Error)]
#[error("PA-CONTROL refused command {code:04X}: command error 0x{quit:02X} ({quit}), {text}")]
pub struct DeviceError {
    /// The command's code.
    pub code: u16,
    pub quit: u16,
    /// Manual 6.5 message.
    pub text: &'static str,
    pub ack: Ack,
}

#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum TransactionError {
    #[error(transparent)]
    Device(#[from] DeviceError),
    #[error("acknowledge received after the transaction finished")]
    AlreadyDone,
}

/// What the master wants to send next.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Outgoing<'a> {
    Poll,
    Command(&'a Command),
}

/// Manual 5.2.6.6 / 5.2.6.7: while a command is unfinished (its last
/// acknowledge had BE = 0, as 0A87 / 0A89 moves do until they arrive) only
/// the poll command may be sent; anything else has to wait, or the move has
/// to be started with 0A94 / 0A95 instead.
pub fn allowed_while_busy(next: Outgoing<'_>) -> bool {
    matches!(next, Outgoing::Poll)
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum State {
    /// Sent, no acknowledge yet.
    AwaitingAck,
    /// Acknowledged with BE = 0; polling.
    Busy,
    Done,
}

#[derive(Debug, Clone, PartialEq)]
pub struct Transaction {
    command: Command,
    options: EncodeOptions,
    poll_interval: Duration,
    state: State,
    polls: u32,
}

impl Transaction {
    pub fn new(command: Command) -> Self {
        Self::with_options(command, EncodeOptions::default())
    }

    pub fn with_options(command: Command, options: EncodeOptions) -> Self {
        Self { command, options, poll_interval: DEFAULT_POLL_INTERVAL, state: State::AwaitingAck, polls: 0 }
    }

    pub fn poll_interval(mut self, interval: Duration) -> Self {
        self.poll_interval = interval;
        self
    }

    pub fn command(&self) -> &Command {
        &self.command
    }

    /// The table row of the command, if the code is known.
    pub fn def(&self) -> Option<&'static table::CommandDef> {
        table::command(self.command.code)
    }

    /// The bytes to send first.
    pub fn request(&self) -> Result<Vec<u8>, EncodeError> {
        let mut buf = Vec::new();
        self.command.encode_with(&self.options, &mut buf)?;
        Ok(buf)
    }

    /// The bytes of a poll; counts it.
    pub fn poll(&mut self) -> [u8; 1] {
        self.polls += 1;
        POLL
    }

    /// Polls sent so far.
    pub fn polls(&self) -> u32 {
        self.polls
    }

    pub fn state(&self) -> State {
        self.state
    }

    /// Whether an acknowledge with BE = 0 is outstanding.
    pub fn is_busy(&self) -> bool {
        self.state == State::Busy
    }

    /// Whether `next` may be sent now (see [`allowed_while_busy`]).
    pub fn allows(&self, next: Outgoing<'_>) -> bool {
        match self.state {
            State::Busy => allowed_while_busy(next),
            // A poll asks for the acknowledge again (the way to recover a
            // lost one without running the command twice); a new command
            // would race the pending one.
            State::AwaitingAck => allowed_while_busy(next),
            State::Done => matches!(next, Outgoing::Command(_)),
        }
    }

    /// Whether `ack` can be this transaction's answer. Acknowledges do not
    /// name their command, but the controller answers in the command's own
    /// data type (manual 3.3, TYP_QUIT), so a successful acknowledge of the
    /// other type belongs to an older exchange: a stale answer left on the
    /// line, e.g. by a client killed mid-exchange. Refusals and unknown codes
    /// are not judged (nothing says which type they carry).
    pub fn could_answer(&self, ack: &Ack) -> bool {
        match self.def() {
            Some(def) if ack.quit == 0 => matches!(
                (def.data_type, ack.q_par),
                (table::DataType::Int, Par2::Int(_)) | (table::DataType::Float, Par2::Float(_))
            ),
            _ => true,
        }
    }

    /// Feeds one acknowledge.
    pub fn handle_ack(&mut self, ack: Ack) -> Result<Step, TransactionError> {
        if self.state == State::Done {
            return Err(TransactionError::AlreadyDone);
        }
        if ack.quit != 0 {
            self.state = State::Done;
            return Err(DeviceError {
                code: self.command.code,
                quit: ack.quit,
                text: table::command_error_text(ack.quit),
                ack,
            }
            .into());
        }
        if ack.be {
            self.state = State::Done;
            Ok(Step::Done(ack))
        } else {
            self.state = State::Busy;
            Ok(Step::NeedPoll { last: ack, after: self.poll_interval })
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::proto::pac::frame::{AckDecoder, CheckRule, Par2};

    fn hex(s: &str) -> Vec<u8> {
        s.split_whitespace().map(|b| u8::from_str_radix(b, 16).unwrap()).collect()
    }

    // Manual 3.4.3: start online, then 0A87 axis 2 to 5552.0 with three polls.
    #[test]
    fn manual_3_4_3_sequence() {
        let mut dec = AckDecoder::new();
        let mut t = Transaction::new(Command::new(0x0603, 0, Par2::Int(0)));
        assert_eq!(t.request().unwrap(), hex("01 02 30 36 30 33 3B 30 3B 30 3B 30 03 31 34 04"));
        dec.push(&hex("01 02 30 3B 31 3B 33 31 3B 30 3B 30 3B 30 03 38 04"));
        let step = t.handle_ack(dec.next().unwrap().unwrap()).unwrap();
        let Step::Done(ack) = step else { panic!("{step:?}") };
        assert_eq!(ack.status, 31);
        assert_eq!(table::operating_status_text(ack.status), "ONLINE");

        let mut t = Transaction::new(Command::new(0x0A87, 2, Par2::Float(5552.0)));
        assert!(t.def().unwrap().is_start_and_wait());
        assert_eq!(t.request().unwrap(), b"\x01\x020A87;2;1;5552.0\x0395\x04");
        assert!(!t.is_busy(), "sent, no acknowledge yet: not busy");
        assert!(t.allows(Outgoing::Poll));
        assert!(!t.allows(Outgoing::Command(&Command::new(0x190B, 0, Par2::Int(0)))));
        let answers = [
            ("01 02 30 3B 30 3B 33 31 3B 30 3B 31 3B 31 32 35 35 2E 30 30 30 03 33 38 04", 1255.0),
            ("01 02 30 3B 30 3B 33 31 3B 30 3B 31 3B 31 35 31 36 2E 39 35 30 03 34 32 04", 1516.95),
            ("01 02 30 3B 30 3B 33 31 3B 30 3B 31 3B 32 36 33 34 2E 37 35 30 03 33 36 04", 2634.75),
        ];
        let other = Command::new(0x190C, 2, Par2::Float(0.0));
        for (bytes, pos) in answers {
            dec.push(&hex(bytes));
            let step = t.handle_ack(dec.next().unwrap().unwrap()).unwrap();
            assert_eq!(step, Step::NeedPoll { last: Ack::decode(&hex(bytes)).unwrap(), after: DEFAULT_POLL_INTERVAL });
            let Step::NeedPoll { last, .. } = step else { unreachable!() };
            assert_eq!(last.q_par, Par2::Float(pos));
            assert!(t.is_busy());
            assert!(t.allows(Outgoing::Poll));
            assert!(!t.allows(Outgoing::Command(&other)));
            assert_eq!(t.poll(), [0x04]);
        }
        dec.push(&hex("01 02 30 3B 31 3B 33 31 3B 30 3B 31 3B 35 35 35 32 2E 30 30 30 03 33 35 04"));
        let step = t.handle_ack(dec.next().unwrap().unwrap()).unwrap();
        let Step::Done(ack) = step else { panic!("{step:?}") };
        assert_eq!(ack.q_par, Par2::Float(5552.0));
        assert_eq!(t.polls(), 3);
        assert_eq!(t.state(), State::Done);
        assert!(t.allows(Outgoing::Command(&other)));
        assert!(!t.is_busy(), "finished: no longer busy");
        assert_eq!(t.handle_ack(ack), Err(TransactionError::AlreadyDone));
    }

    #[test]
    fn an_acknowledge_of_the_other_type_cannot_answer() {
        let ack = |quit, q_par| Ack { quit, be: true, status: 31, error: 0, q_par, check_rule: CheckRule::Strict };
        // 1910 reads an integer; a position (190C, float) left on the line is not its answer.
        let read_int = Transaction::new(Command::new(0x1910, 1, Par2::Int(0)));
        assert!(read_int.could_answer(&ack(0, Par2::Int(3))));
        assert!(!read_int.could_answer(&ack(0, Par2::Float(161.477))));
        let read_pos = Transaction::new(Command::new(0x190C, 1, Par2::Float(0.0)));
        assert!(read_pos.could_answer(&ack(0, Par2::Float(161.477))));
        assert!(!read_pos.could_answer(&ack(0, Par2::Int(3))));
        // A refusal carries no promise about its type.
        assert!(read_pos.could_answer(&ack(0x20, Par2::Int(0))));
        assert!(Transaction::new(Command::new(0x0999, 0, Par2::Int(0))).could_answer(&ack(0, Par2::Float(1.0))));
    }

    #[test]
    fn device_error_carries_text() {
        let mut t = Transaction::new(Command::new(0x0A87, 9, Par2::Float(1.0)));
        let ack =
            Ack { quit: 0x20, be: true, status: 31, error: 0, q_par: Par2::Int(0), check_rule: CheckRule::Strict };
        let err = t.handle_ack(ack).unwrap_err();
        let TransactionError::Device(d) = &err else { panic!("{err:?}") };
        assert_eq!(d.quit, 32);
        assert_eq!(d.text, "axis number unknown");
        assert_eq!(err.to_string(), "PA-CONTROL refused command 0A87: command error 0x20 (32), axis number unknown");
        assert_eq!(t.state(), State::Done);
        // A command error wins over BE = 0.
        let mut t = Transaction::new(Command::new(0x0603, 0, Par2::Int(0)));
        let ack = Ack { quit: 0x2C, be: false, ..ack };
        assert!(matches!(t.handle_ack(ack), Err(TransactionError::Device(DeviceError { quit: 44, .. }))));
    }

    #[test]
    fn options_and_interval() {
        let opts = EncodeOptions { check_rule: CheckRule::WithEtx, ..Default::default() };
        let mut t = Transaction::with_options(Command::new(0x1900, 5, Par2::Int(0)), opts)
            .poll_interval(Duration::from_millis(200));
        assert_eq!(t.request().unwrap(), b"\x01\x021900;5;0;0\x035\x04");
        let ack = Ack { quit: 0, be: false, status: 1, error: 0, q_par: Par2::Int(1), check_rule: CheckRule::Strict };
        assert_eq!(t.handle_ack(ack), Ok(Step::NeedPoll { last: ack, after: Duration::from_millis(200) }));
        assert!(allowed_while_busy(Outgoing::Poll));
        assert!(!allowed_while_busy(Outgoing::Command(t.command())));
    }
}
