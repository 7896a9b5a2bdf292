//! Which Cdios answer belongs to which command, sans-IO.
//!
//! A blocking session (or anything else that moves frames) sends
//! [`Exchange::frame`], waits as [`Exchange::wait`] says, sorts every received
//! frame with [`incoming`] and asks [`Exchange::handle`] what an answer is to
//! its command. [`Burst`] does the same for several reads of one module sent
//! at once. Nothing here performs I/O or reads a clock.

use std::time::Duration;

use super::table::{self, Confirm, DecodedReply, ReplySelector};
use super::transport::{self, Answer, AnswerKind, ErrorReply};
use super::{Address, NodeId};
use crate::proto::{CanFrame, DecodeError};

/// How long an error is awaited for a confirmation that is switched off.
pub const NO_CONFIRM_WINDOW: Duration = Duration::from_millis(50);
/// 05h: "EEPROM erasing / programming takes 260 up to 750 milliseconds, then
/// the reply message is sent"; this is on top of the normal timeout.
pub const STORE_TIME: Duration = Duration::from_millis(750);

/// General error codes after which the same read may succeed a little
/// later: the controller is initialising (the first 500 ms) or writing its
/// EEPROM.
const GENERAL_INITIALISING: u8 = 4;
const GENERAL_EEPROM_BUSY: u8 = 8;

/// Whether an error reply says "busy, ask again" rather than "no".
pub fn is_busy(e: &ErrorReply) -> bool {
    matches!(e.general, GENERAL_INITIALISING | GENERAL_EEPROM_BUSY)
}

/// What a frame on the bus is to a Cdios master.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Incoming {
    /// Not a Cdios answer id (another family, a command, NMT).
    Foreign,
    /// On an answer id but without a code byte to tell what it is.
    Undecodable(DecodeError),
    /// Unsolicited (code | 0x40): never the answer to a command.
    Event(Answer),
    /// A reply or an error reply, to be matched.
    Answer(Answer),
}

pub fn incoming(frame: &CanFrame) -> Incoming {
    match Answer::from_frame(frame) {
        Ok(None) => Incoming::Foreign,
        Err(e) => Incoming::Undecodable(e),
        Ok(Some(a)) if a.kind == AnswerKind::Event => Incoming::Event(a),
        Ok(Some(a)) => Incoming::Answer(a),
    }
}

/// What an answer is to the command of an [`Exchange`].
#[derive(Debug, Clone, PartialEq)]
pub enum Verdict {
    /// The command's reply (a read's decodes with the command's row).
    Reply,
    /// The command's error reply.
    Refused(ErrorReply),
    /// The command's reply, but it does not decode as the command's row.
    Malformed(DecodeError),
    /// Another node or module.
    OtherTarget,
    /// The same module answering another command.
    OtherCommand,
}

/// How long to wait for the answer, and whether one must come.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Wait {
    pub timeout: Duration,
    /// `false`: the confirmation is switched off; silence means accepted.
    pub need_reply: bool,
}

/// One command to one module (or the controller) of a node.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Exchange {
    pub node: NodeId,
    pub address: Address,
    pub data: [u8; 8],
}

impl Exchange {
    pub fn new(node: NodeId, address: Address, data: [u8; 8]) -> Self {
        Self { node, address, data }
    }

    pub fn frame(&self) -> CanFrame {
        transport::command_frame(self.node, &self.data)
    }

    fn def(&self) -> Option<&'static table::CommandDef> {
        table::command_for(self.data[0], self.data[2])
    }

    /// Reads have reply fields; only they may be sent again.
    pub fn is_read(&self) -> bool {
        self.def().is_some_and(|d| !d.reply.fields.is_empty())
    }

    /// The wait for a node whose confirmations are on (`confirm`) or off,
    /// with `timeout` the usual answer timeout: 05h gets the EEPROM time on
    /// top, commands that are always answered wait as usual, and the others
    /// wait only a short window for an error when confirmations are off.
    pub fn wait(&self, timeout: Duration, confirm: bool) -> Wait {
        let always = self.def().is_none_or(|d| d.confirm == Confirm::Always);
        if self.data[0] == table::STORE_CONFIGURATION {
            Wait { timeout: timeout + STORE_TIME, need_reply: true }
        } else if confirm || always {
            Wait { timeout, need_reply: true }
        } else {
            Wait { timeout: timeout.min(NO_CONFIRM_WINDOW), need_reply: false }
        }
    }

    fn is_mine(&self, a: &Answer) -> bool {
        a.node == self.node && Address::from_byte(a.module) == self.address
    }

    pub fn handle(&self, a: &Answer) -> Verdict {
        if !self.is_mine(a) {
            return Verdict::OtherTarget;
        }
        match a.kind {
            AnswerKind::Error if a.command == self.data[0] => match ErrorReply::decode(&a.data) {
                Ok(e) => Verdict::Refused(e),
                Err(e) => Verdict::Malformed(e),
            },
            AnswerKind::Reply if is_reply_to(a, &self.data) => match a.reply().map(|r| check_row(r, &self.data)) {
                Some(Err(e)) if self.is_read() => Verdict::Malformed(e),
                _ => Verdict::Reply,
            },
            _ => Verdict::OtherCommand,
        }
    }
}

/// Several reads of one module sent at once, and the replies matched so far.
#[derive(Debug)]
pub struct Burst {
    node: NodeId,
    address: Address,
    data: Vec<[u8; 8]>,
    got: Vec<Option<DecodedReply>>,
    pending: usize,
}

/// What an answer did to a [`Burst`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Settled {
    /// The reply of read `i`.
    Read(usize),
    /// Not for this module.
    OtherTarget,
    /// An error or an odd reply: the read it concerns goes again on its own.
    LeftForSingle,
}

impl Burst {
    /// Whether the reads can go as one burst: more than one, and every reply
    /// told apart from the others.
    pub fn pipelinable(data: &[[u8; 8]]) -> bool {
        data.len() > 1 && data.iter().enumerate().all(|(i, a)| data[..i].iter().all(|b| !same_reply(a, b)))
    }

    pub fn new(node: NodeId, address: Address, data: &[[u8; 8]]) -> Self {
        Self { node, address, data: data.to_vec(), got: vec![None; data.len()], pending: data.len() }
    }

    pub fn frames(&self) -> impl Iterator<Item = CanFrame> + '_ {
        let node = self.node;
        self.data.iter().map(move |d| transport::command_frame(node, d))
    }

    pub fn handle(&mut self, a: &Answer) -> Settled {
        if a.node != self.node || Address::from_byte(a.module) != self.address {
            return Settled::OtherTarget;
        }
        let slot = self.data.iter().position(|d| a.kind == AnswerKind::Reply && is_reply_to(a, d));
        match (slot, a.reply()) {
            (Some(i), Some(Ok(r))) if self.got[i].is_none() && check_row(Ok(r.clone()), &self.data[i]).is_ok() => {
                self.got[i] = Some(r);
                self.pending -= 1;
                Settled::Read(i)
            }
            _ => Settled::LeftForSingle,
        }
    }

    pub fn pending(&self) -> usize {
        self.pending
    }

    /// The replies in command order; `None` for a read not answered.
    pub fn into_replies(self) -> Vec<Option<DecodedReply>> {
        self.got
    }
}

/// Whether the replies to two commands look alike (same reply code, and no
/// echoed selector to tell them apart).
pub fn same_reply(a: &[u8; 8], b: &[u8; 8]) -> bool {
    let (Some(da), Some(db)) = (table::command_for(a[0], a[2]), table::command_for(b[0], b[2])) else { return true };
    da.reply.code == db.reply.code && (da.reply.selector != ReplySelector::Echo || a[2] == b[2])
}

/// Whether `a` is the normal reply to the command `data`.
pub fn is_reply_to(a: &Answer, data: &[u8; 8]) -> bool {
    let Some(def) = table::command_for(data[0], data[2]) else { return a.data[0] == data[0] };
    a.data[0] == def.reply.code && (def.reply.selector != ReplySelector::Echo || a.data[2] == data[2])
}

/// A matched reply must decode with the row of the command it answers.
pub fn check_row(r: Result<DecodedReply, DecodeError>, data: &[u8; 8]) -> Result<(), DecodeError> {
    let r = r?;
    let want = table::command_for(data[0], data[2]).map(|d| d.key);
    let got = r.def.map(|d| d.key);
    // Set and read rows of one code share the reply code; a read is known by its fields.
    let same_layout = match (want.and_then(table::command), r.def) {
        (Some(w), Some(g)) => w.reply.fields == g.reply.fields,
        _ => false,
    };
    if same_layout {
        Ok(())
    } else {
        Err(DecodeError::Malformed(format!("reply decodes as {got:?}, expected {want:?}")))
    }
}

#[cfg(test)]
mod tests {
    use super::super::ModuleId;
    use super::*;

    fn f(s: &str) -> CanFrame {
        s.parse().unwrap()
    }

    fn answer(s: &str) -> Answer {
        match incoming(&f(s)) {
            Incoming::Answer(a) | Incoming::Event(a) => a,
            other => panic!("{s}: {other:?}"),
        }
    }

    fn node1() -> NodeId {
        NodeId::new(1).unwrap()
    }

    fn m(id: u8) -> Address {
        Address::Module(ModuleId::new(id).unwrap())
    }

    fn data(s: &str) -> [u8; 8] {
        transport::padded(f(s).data()).unwrap()
    }

    // Specs README / CLI contract: `cdios-goto -m 1 --node 1 5000` is 201#2301008813000000.
    #[test]
    fn goto_confirmation_error_and_foreign_frames() {
        let ex = Exchange::new(node1(), m(1), data("201#2301008813000000"));
        assert_eq!(ex.frame().to_string(), "201#2301008813000000");
        assert!(!ex.is_read());
        assert_eq!(ex.handle(&answer("181#23010000")), Verdict::Reply);
        assert_eq!(ex.handle(&answer("181#23000000")), Verdict::OtherTarget, "module 0");
        assert_eq!(ex.handle(&answer("182#23010000")), Verdict::OtherTarget, "node 2");
        assert_eq!(ex.handle(&answer("181#25010000")), Verdict::OtherCommand);
        // An error about another command (25h) of the same module is not
        // this goto's refusal: failing the goto on it would report a fault
        // the goto never had.
        assert_eq!(ex.handle(&answer("181#A501000400000000")), Verdict::OtherCommand);
        let Verdict::Refused(e) = ex.handle(&answer("181#A301000400000000")) else { panic!() };
        assert_eq!((e.command, e.general), (0x23, 4));
        assert!(is_busy(&e), "general error 4: initialising");
        assert!(!is_busy(&ErrorReply::new(0x23, 1, 1, 0, 0)), "general error 1: no module");
        assert_eq!(incoming(&f("0A3#0b0464")), Incoming::Foreign, "a PowerCube acknowledge");
        assert!(matches!(incoming(&f("181#")), Incoming::Undecodable(_)));
        assert!(matches!(incoming(&f("181#6100007b00000000")), Incoming::Event(_)));
    }

    #[test]
    fn a_read_is_matched_by_its_selector_and_row() {
        // 21h selector 2: the setpoint; selector 0 is the current position.
        let ex = Exchange::new(node1(), m(0), data("201#2100020000000000"));
        assert!(ex.is_read());
        assert_eq!(ex.handle(&answer("181#2100020900000000")), Verdict::Reply);
        assert_eq!(ex.handle(&answer("181#2100000200000000")), Verdict::OtherCommand);
        // 10h selector 80h is answered with 11h.
        let dout = Exchange::new(node1(), m(0), data("201#1000800000000000"));
        assert_eq!(dout.handle(&answer("181#1100000500000000")), Verdict::Reply);
    }

    // A code the table does not know is answered by the same code.
    #[test]
    fn an_unknown_code_is_matched_by_its_code() {
        let raw = Exchange::new(node1(), m(0), data("201#3E00000000000000"));
        assert!(table::command_for(0x3E, 0).is_none());
        assert_eq!(raw.handle(&answer("181#3E00000000000000")), Verdict::Reply);
        assert_eq!(raw.handle(&answer("181#2100000000000000")), Verdict::OtherCommand);
    }

    #[test]
    fn waits_follow_the_confirm_setting() {
        let t = Duration::from_millis(100);
        let store = Exchange::new(node1(), Address::Controller, [0x05, 0xFF, 0, 0, 0, 0, 0, 0]);
        assert_eq!(store.wait(t, true), Wait { timeout: t + STORE_TIME, need_reply: true });
        let goto = Exchange::new(node1(), m(1), data("201#2301008813000000"));
        assert_eq!(goto.wait(t, true), Wait { timeout: t, need_reply: true });
        assert_eq!(goto.wait(t, false), Wait { timeout: NO_CONFIRM_WINDOW, need_reply: false });
        let read = Exchange::new(node1(), m(0), data("201#2100000000000000"));
        assert_eq!(read.wait(t, false), Wait { timeout: t, need_reply: true }, "reads are always answered");
    }

    #[test]
    fn a_burst_settles_each_read_once() {
        let reads = [data("201#2100000000000000"), data("201#2600000000000000")];
        assert!(Burst::pipelinable(&reads));
        assert!(!Burst::pipelinable(&reads[..1]));
        assert!(!Burst::pipelinable(&[reads[0], reads[0]]));
        let mut b = Burst::new(node1(), m(0), &reads);
        assert_eq!(b.pending(), 2);
        assert_eq!(
            b.frames().map(|f| f.to_string()).collect::<Vec<_>>(),
            ["201#2100000000000000", "201#2600000000000000"]
        );
        assert_eq!(b.handle(&answer("181#2600000081008010")), Settled::Read(1));
        assert_eq!(b.handle(&answer("181#2600000081008010")), Settled::LeftForSingle, "answered already");
        assert_eq!(b.handle(&answer("181#A100000400000000")), Settled::LeftForSingle);
        assert_eq!(b.handle(&answer("181#2101000900000000")), Settled::OtherTarget);
        assert_eq!(b.pending(), 1);
        assert_eq!(b.handle(&answer("181#210000B0FBFFFF00")), Settled::Read(0));
        assert_eq!(b.pending(), 0);
        let got = b.into_replies();
        assert_eq!(got[0].as_ref().unwrap().get("position"), Some(-1104));
    }

    // A burst settles only a reply that decodes with its command's row. The
    // confirmation of 20h (set servo speeds) names it by its code, but with
    // 80h in the selector byte it decodes as the read of the servo speeds:
    // that is not this set's confirmation, so it goes again on its own.
    #[test]
    fn a_burst_leaves_a_reply_that_decodes_with_another_row() {
        let cmds = [data("201#2100000000000000"), data("201#2000000000000000")];
        assert!(Burst::pipelinable(&cmds));
        let mut b = Burst::new(node1(), m(0), &cmds);
        let odd = answer("181#2000800000000000");
        assert!(is_reply_to(&odd, &cmds[1]), "it names the set");
        assert_eq!(b.handle(&odd), Settled::LeftForSingle);
        assert_eq!(b.pending(), 2);
        assert_eq!(b.handle(&answer("181#2000000000000000")), Settled::Read(1));
        assert_eq!(b.pending(), 1);
    }

    // Why `Exchange::handle` never finds a read's reply malformed with the
    // table as it is: every reply that names a read (its code, and its
    // selector where echoed) decodes with that read's layout. The guard
    // only matters for a row added that breaks this, and then this fails.
    #[test]
    fn every_reply_that_names_a_read_decodes_with_its_layout() {
        for c in table::COMMANDS {
            for sel in (0..=255u8).filter(|&s| c.selector(s).is_some()) {
                let cmd = [c.code, 0, sel, 0, 0, 0, 0, 0];
                let read = Exchange::new(node1(), m(0), cmd);
                if !read.is_read() {
                    continue;
                }
                let code = table::command_for(c.code, sel).unwrap().reply.code;
                for echoed in 0..=255u8 {
                    let a = Answer::from_data(node1(), &[code, 0, echoed, 0, 0, 0, 0, 0]).unwrap();
                    if is_reply_to(&a, &cmd) {
                        assert_eq!(read.handle(&a), Verdict::Reply, "{} {sel:#04x}: {:02x?}", c.key, a.data);
                    }
                }
            }
        }
    }
}
