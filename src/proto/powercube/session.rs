//! Which PowerCube answer belongs to which request, sans-IO.
//!
//! A blocking session (or anything else that moves frames) encodes the
//! requests with [`CanExchange::frames`] / [`rs232_request`], hands every
//! received frame to [`CanExchange::handle`] / [`rs232_verdict`] and keeps
//! the clock itself: nothing here performs I/O or reads a clock.

use super::can::{self as pc_can};
use super::rs232::{self, Direction, Rs232Frame};
use super::{ModuleId, Request, Response};
use crate::proto::{CanFrame, DecodeError};

/// The module whose acknowledge id (`0x0A0 + M`) `frame` is on, whatever its data.
pub fn ack_module(frame: &CanFrame) -> Option<ModuleId> {
    let id = frame.id();
    if frame.is_extended() || id & !0x1F != pc_can::ACK_BASE {
        return None;
    }
    ModuleId::new((id & 0x1F) as u8)
}

/// Whether `frame` answers `req` sent to `module`: `Some(Ok)` for its
/// acknowledge, `Some(Err)` for a frame on the module's acknowledge id that
/// could be the answer (same command byte) but does not decode, `None` for
/// anything else (another module, another command, another family).
pub fn can_answer(module: ModuleId, req: &Request, frame: &CanFrame) -> Option<Result<Response, DecodeError>> {
    match pc_can::ack_from(module, frame)? {
        Ok(resp) if req.matches(&resp) => Some(Ok(resp)),
        Err(e) if frame.data().first() == Some(&(req.command() as u8)) => Some(Err(e)),
        _ => None,
    }
}

/// Requests pipelined on CAN and the answers collected so far: every
/// request goes out first, then each received frame settles at most one of
/// them (the first one still waiting that it answers).
#[derive(Debug)]
pub struct CanExchange {
    reqs: Vec<(ModuleId, Request)>,
    answers: Vec<Option<Result<Response, DecodeError>>>,
    pending: usize,
}

impl CanExchange {
    pub fn new(reqs: &[(ModuleId, Request)]) -> Self {
        Self { reqs: reqs.to_vec(), answers: reqs.iter().map(|_| None).collect(), pending: reqs.len() }
    }

    /// The requests, in order.
    pub fn requests(&self) -> &[(ModuleId, Request)] {
        &self.reqs
    }

    /// The request frames, in order.
    pub fn frames(&self) -> impl Iterator<Item = CanFrame> + '_ {
        self.reqs.iter().map(|(m, r)| pc_can::request_frame(*m, r))
    }

    /// Feeds a received frame; the index of the request it settled, if any.
    pub fn handle(&mut self, frame: &CanFrame) -> Option<usize> {
        for (i, (m, r)) in self.reqs.iter().enumerate() {
            if self.answers[i].is_some() {
                continue;
            }
            if let Some(answer) = can_answer(*m, r, frame) {
                self.answers[i] = Some(answer);
                self.pending -= 1;
                return Some(i);
            }
        }
        None
    }

    /// Requests not answered yet.
    pub fn pending(&self) -> usize {
        self.pending
    }

    /// The answers in request order; `None` for a request not answered.
    pub fn into_answers(self) -> Vec<Option<Result<Response, DecodeError>>> {
        self.answers
    }
}

/// The RS232 bytes of `req` to `module`.
pub fn rs232_request(module: ModuleId, req: &Request, out: &mut Vec<u8>) {
    rs232::encode(Direction::ToModule, module.get(), req.to_payload().as_slice(), out);
}

/// What one item of the RS232 decoder is to `req` sent to `module`.
#[derive(Debug, Clone, PartialEq)]
pub enum Rs232Verdict {
    /// The acknowledge; `declared_len` differs from the framed length when
    /// the module's TELID says otherwise (the answer is still good).
    Answer { response: Response, declared_len: u8, framed_len: u8 },
    /// The module answered another command.
    OtherCommand,
    /// Another module's frame, or a request echoed on the line.
    Foreign,
    /// The answer (or a frame with a bad checksum) cannot be used.
    Malformed(DecodeError),
    /// Bytes the decoder dropped (no frame); not an answer to anything.
    Dropped(DecodeError),
}

pub fn rs232_verdict(module: ModuleId, req: &Request, item: Result<&Rs232Frame, &DecodeError>) -> Rs232Verdict {
    match item {
        Ok(frame) if frame.dir == Direction::FromModule && frame.module == module.get() => {
            match Response::decode(frame.payload.as_slice()) {
                Ok(response) if req.matches(&response) => Rs232Verdict::Answer {
                    response,
                    declared_len: frame.declared_len,
                    framed_len: frame.payload.len() as u8,
                },
                Ok(_) => Rs232Verdict::OtherCommand,
                Err(e) => Rs232Verdict::Malformed(e),
            }
        }
        Ok(_) => Rs232Verdict::Foreign,
        Err(e @ DecodeError::Checksum { .. }) => Rs232Verdict::Malformed(e.clone()),
        Err(e) => Rs232Verdict::Dropped(e.clone()),
    }
}

#[cfg(test)]
mod tests {
    use super::super::table::{ids, CommandId};
    use super::*;

    fn m(id: u8) -> ModuleId {
        ModuleId::new(id).unwrap()
    }

    fn f(s: &str) -> CanFrame {
        s.parse().unwrap()
    }

    // Manual section 8, module 17: GetExtended on 0x0D1, its answer on 0x0B1.
    #[test]
    fn can_burst_settles_each_request_by_module_and_command() {
        let reqs = [(m(17), Request::GetExtended { param: 0x27 }), (m(17), Request::Home), (m(3), Request::Home)];
        let mut ex = CanExchange::new(&reqs);
        let frames: Vec<String> = ex.frames().map(|f| f.to_string()).collect();
        assert_eq!(frames, ["0D1#0A27", "0F1#01", "0E3#01"]);
        assert_eq!(ex.handle(&f("0B1#00")), None, "a Reset ack answers neither");
        assert_eq!(ex.handle(&f("181#2600000000000000")), None, "a Cdios reply is foreign");
        assert_eq!(ex.handle(&f("0A3#01")), Some(2));
        assert_eq!(ex.handle(&f("0B1#0A2702000000")), Some(0));
        assert_eq!(ex.handle(&f("0A3#01")), None, "module 3 is answered already");
        assert_eq!(ex.pending(), 1);
        assert_eq!(ex.handle(&f("0B1#01")), Some(1));
        let answers = ex.into_answers();
        assert_eq!(answers[1], Some(Ok(Response::Simple(CommandId::Home))));
        assert!(matches!(answers[0], Some(Ok(Response::Get { param: 0x27, .. }))));
    }

    #[test]
    fn acknowledge_ids_name_their_module() {
        assert_eq!(ack_module(&f("0B1#FF")), ModuleId::new(17));
        assert_eq!(ack_module(&f("0A3#")), ModuleId::new(3));
        for other in ["0A0#00", "0D1#0A27", "181#23", "100#0700", "000000B1#01"] {
            assert_eq!(ack_module(&f(other)), None, "{other}");
        }
    }

    #[test]
    fn an_undecodable_frame_is_malformed_only_with_the_command_byte() {
        let req = Request::GetExtended { param: ids::ACT_POS };
        assert!(matches!(can_answer(m(17), &req, &f("0B1#0A")), Some(Err(_))));
        assert_eq!(can_answer(m(17), &req, &f("0B1#FF")), None);
        assert_eq!(can_answer(m(17), &req, &f("0B2#0A3C0000403F")), None, "module 18");
    }

    // Manual section 9, module 17: Home and SetExtended ACC = 0.5, byte for byte.
    #[test]
    fn rs232_section_9_home_and_set_acc() {
        use super::super::frame::Value;
        let mut bytes = Vec::new();
        rs232_request(m(17), &Request::Home, &mut bytes);
        assert_eq!(bytes, [0x02, 0x06, 0x21, 0x01, 0x28, 0x03]);
        let set_acc = Request::set(0x50, Value::Float(0.5));
        bytes.clear();
        rs232_request(m(17), &set_acc, &mut bytes);
        assert_eq!(bytes, [0x02, 0x06, 0x26, 0x08, 0x50, 0x00, 0x00, 0x00, 0x3f, 0xc3, 0x03]);
        let mut dec = rs232::Decoder::new();
        // Home's ack, a request echoed on the line, then SetExtended's ack.
        dec.push(&[0x02, 0x0a, 0x21, 0x01, 0x2c, 0x03]);
        dec.push(&[0x02, 0x06, 0x21, 0x01, 0x28, 0x03]);
        dec.push(&[0x02, 0x0a, 0x26, 0x08, 0x50, 0x64, 0xec, 0x03]);
        let mut verdicts = Vec::new();
        while let Some(item) = dec.next_frame() {
            verdicts.push(rs232_verdict(m(17), &set_acc, item.as_ref()));
        }
        assert_eq!(verdicts[..2], [Rs232Verdict::OtherCommand, Rs232Verdict::Foreign]);
        assert!(
            matches!(verdicts[2], Rs232Verdict::Answer { response: Response::SetAck { param: 0x50 }, .. }),
            "{verdicts:?}"
        );
        let ack17 =
            Rs232Frame { dir: Direction::FromModule, module: 17, payload: Request::Home.to_payload(), declared_len: 1 };
        let home = rs232_verdict(m(3), &Request::Home, Ok(&ack17));
        assert_eq!(home, Rs232Verdict::Foreign, "module 17 does not answer for module 3");
        let bad = DecodeError::Checksum { computed: 1, received: 2 };
        assert!(matches!(rs232_verdict(m(17), &Request::Home, Err(&bad)), Rs232Verdict::Malformed(_)));
        let garbage = DecodeError::TooShort { need: 3, got: 0 };
        assert!(matches!(rs232_verdict(m(17), &Request::Home, Err(&garbage)), Rs232Verdict::Dropped(_)));
    }
}
