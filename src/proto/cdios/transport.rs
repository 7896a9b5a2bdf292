//! Cdios on CAN (CANopen variant, specs README "Cdios 6168"): the node is
//! started with NMT `id 0x000, [0x01, node]`; commands go to `0x200 + node`;
//! replies, events and errors come from `0x180 + node`. The module is chosen
//! by data byte 2, never by the CAN id. Frames may be shorter than 8 bytes
//! ("variable length messages"): the missing bytes read as zero.

use super::table::{self, Flag};
pub use super::table::{classify_code, padded, AnswerKind};
use super::NodeId;
use crate::proto::{CanFrame, DecodeError};

pub const NMT_ID: u32 = 0x000;
/// NMT "start remote node".
pub const NMT_START: u8 = 0x01;
pub const COMMAND_BASE: u32 = 0x200;
pub const ANSWER_BASE: u32 = 0x180;
/// What a node needs after NMT start before it takes commands.
pub const START_DELAY_MS: u64 = 100;

/// NMT start of `node`.
pub fn nmt_start(node: NodeId) -> CanFrame {
    CanFrame::new(NMT_ID, &[NMT_START, node.get()]).expect("standard id, 2 bytes")
}

/// The frame carrying a command's 8 data bytes to `node`.
pub fn command_frame(node: NodeId, data: &[u8; 8]) -> CanFrame {
    CanFrame::new(COMMAND_BASE + u32::from(node.get()), data).expect("id <= 0x27F, 8 bytes")
}

/// The frame a node answers with (for simulators).
pub fn answer_frame(node: NodeId, data: &[u8; 8]) -> CanFrame {
    CanFrame::new(ANSWER_BASE + u32::from(node.get()), data).expect("id <= 0x1FF, 8 bytes")
}

/// Any frame from `0x180 + node`, classified.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub struct Answer {
    pub node: NodeId,
    pub kind: AnswerKind,
    /// The command code this answers (10h for an 11h reply).
    pub command: u8,
    /// Data byte 2: the module (or > 15 for the controller).
    pub module: u8,
    /// The data bytes, zero-padded.
    pub data: [u8; 8],
    /// Bytes actually on the bus.
    pub dlc: u8,
}

impl Answer {
    /// `Ok(None)` for frames that are not Cdios answers.
    pub fn from_frame(frame: &CanFrame) -> Result<Option<Self>, DecodeError> {
        let Some(node) = answer_node(frame) else { return Ok(None) };
        Self::from_data(node, frame.data()).map(Some)
    }

    pub fn from_data(node: NodeId, data: &[u8]) -> Result<Self, DecodeError> {
        if data.len() > 8 {
            return Err(DecodeError::TooLong { len: data.len() });
        }
        let d = padded(data).ok_or(DecodeError::TooShort { need: 1, got: 0 })?;
        let (kind, command) = classify_code(d[0]);
        Ok(Self { node, kind, command, module: d[1], data: d, dlc: data.len() as u8 })
    }

    /// Whether this answers a command with `code` sent to `module`.
    pub fn answers(&self, code: u8, module: u8) -> bool {
        self.command == code && self.module == module
    }

    /// The reply or event, decoded with the table.
    pub fn reply(&self) -> Option<Result<table::DecodedReply, DecodeError>> {
        (self.kind != AnswerKind::Error).then(|| table::decode_reply(&self.data))
    }

    /// The error reply, decoded.
    pub fn error(&self) -> Option<ErrorReply> {
        (self.kind == AnswerKind::Error).then(|| ErrorReply::from_padded(&self.data))
    }
}

/// The node of a frame on `0x181..=0x1FF`.
pub fn answer_node(frame: &CanFrame) -> Option<NodeId> {
    let id = frame.id();
    if frame.is_extended() || !(ANSWER_BASE..ANSWER_BASE + 0x80).contains(&id) {
        return None;
    }
    NodeId::new((id - ANSWER_BASE) as u8)
}

/// The node of a frame on `0x201..=0x27F`.
pub fn command_node(frame: &CanFrame) -> Option<NodeId> {
    let id = frame.id();
    if frame.is_extended() || !(COMMAND_BASE..COMMAND_BASE + 0x80).contains(&id) {
        return None;
    }
    NodeId::new((id - COMMAND_BASE) as u8)
}

/// `[code|0x80, module, 0, general, status1, status2, 0, 0]`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub struct ErrorReply {
    /// The code on the wire (96h or 56h for 16h).
    pub code: u8,
    /// The command it refuses.
    pub command: u8,
    pub module: u8,
    pub general: u8,
    pub status1: u8,
    pub status2: u8,
}

impl ErrorReply {
    /// Any data whose code byte classifies as an error.
    pub fn decode(data: &[u8]) -> Result<Self, DecodeError> {
        if data.len() > 8 {
            return Err(DecodeError::TooLong { len: data.len() });
        }
        let d = padded(data).ok_or(DecodeError::TooShort { need: 1, got: 0 })?;
        match classify_code(d[0]) {
            (AnswerKind::Error, _) => Ok(Self::from_padded(&d)),
            _ => Err(DecodeError::Malformed(format!("{:#04x} is not an error code", d[0]))),
        }
    }

    fn from_padded(d: &[u8; 8]) -> Self {
        let (_, command) = classify_code(d[0]);
        Self { code: d[0], command, module: d[1], general: d[3], status1: d[4], status2: d[5] }
    }

    /// The error a module sends for `command` (code | 0x80; for simulators).
    pub fn new(command: u8, module: u8, general: u8, status1: u8, status2: u8) -> Self {
        Self { code: command | 0x80, command: command & 0x7F, module, general, status1, status2 }
    }

    pub fn to_data(&self) -> [u8; 8] {
        [self.code, self.module, 0, self.general, self.status1, self.status2, 0, 0]
    }

    /// `(name, text)` of the general error code, if it is one of 0..=8.
    pub fn general_error(&self) -> Option<(&'static str, &'static str)> {
        table::general_error(self.general)
    }

    /// The command's error bits that are set.
    pub fn flags(&self) -> Vec<&'static Flag> {
        let bytes = [self.status1, self.status2];
        table::error_bits(self.command).iter().filter(|f| f.is_set(&bytes)).collect()
    }

    /// Set bits that the command's table does not list, as `(status 1..2, bit)`.
    pub fn unknown_bits(&self) -> Vec<(u8, u8)> {
        let table = table::error_bits(self.command);
        let mut out = Vec::new();
        for (i, b) in [self.status1, self.status2].iter().enumerate() {
            let byte = i as u8 + 1;
            for bit in 0..8u8 {
                if b & (1 << bit) != 0 && !table.iter().any(|f| f.byte == byte && f.bit == bit) {
                    out.push((byte, bit));
                }
            }
        }
        out
    }

    /// One line for humans: general code text, or the set bits.
    pub fn describe(&self) -> String {
        let mut parts: Vec<String> = Vec::new();
        match self.general_error() {
            Some((_, text)) if self.general != 0 => parts.push(text.to_string()),
            None => parts.push(format!("general error code {}", self.general)),
            _ => {}
        }
        parts.extend(self.flags().iter().map(|f| f.meaning.to_string()));
        parts.extend(self.unknown_bits().iter().map(|(s, b)| format!("status{s} bit {b}")));
        if parts.is_empty() {
            parts.push("no error bits set".into());
        }
        format!("command {:#04x} module {}: {}", self.command, self.module, parts.join("; "))
    }
}

/// Any Cdios frame on the bus, classified (for traces and simulators).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BusMessage {
    /// NMT on id 0: `[command, node]` (node 0 = all nodes).
    Nmt {
        command: u8,
        node: u8,
    },
    Command {
        node: NodeId,
        data: [u8; 8],
    },
    Answer(Answer),
}

/// `Ok(None)` for frames that are not Cdios'.
pub fn classify(frame: &CanFrame) -> Result<Option<BusMessage>, DecodeError> {
    if frame.is_extended() {
        return Ok(None);
    }
    if frame.id() == NMT_ID {
        let d = frame.data();
        if d.len() < 2 {
            return Err(DecodeError::TooShort { need: 2, got: d.len() });
        }
        return Ok(Some(BusMessage::Nmt { command: d[0], node: d[1] }));
    }
    if let Some(node) = command_node(frame) {
        let data = padded(frame.data()).ok_or(DecodeError::TooShort { need: 1, got: 0 })?;
        return Ok(Some(BusMessage::Command { node, data }));
    }
    Ok(Answer::from_frame(frame)?.map(BusMessage::Answer))
}
