//! The Cdios's frames as they read on a shared CAN bus, for `monitor` and
//! `send`: NMT, commands, replies, events and error replies in words, and
//! which commands start a motor. The family registry hands them to the bus
//! decoder (`family::Family::describe_can`).

use serde_json::json;

use super::transport::{self, AnswerKind, BusMessage};
use super::{table, Address};
use crate::proto::bus::BusFrame;
use crate::proto::CanFrame;

/// Why sending `frame` by hand may set something moving, if it is a Cdios
/// command that may: GOTO, START, or one that does not decode.
pub fn motion_of(frame: &CanFrame) -> Option<String> {
    match transport::classify(frame) {
        Ok(Some(BusMessage::Command { node, data })) => match table::decode_command(&data) {
            Ok(d) if [table::GOTO, table::START].contains(&d.def.code) => {
                Some(format!("Cdios {} starts a motor of node {node}", d.def.key))
            }
            Ok(_) => None,
            Err(e) => Some(format!("a Cdios command that does not decode ({e}): it may start a motor")),
        },
        _ => None,
    }
}

/// A Cdios frame (NMT 0x000, commands 0x201.., answers 0x181..) taken
/// apart; `None` for any other frame.
pub fn describe(frame: &CanFrame) -> Option<BusFrame> {
    let msg = match transport::classify(frame) {
        Ok(Some(m)) => m,
        Ok(None) => return None,
        Err(e) => {
            let mut i = BusFrame::new("raw", String::new());
            i.error = Some(e.to_string());
            return Some(i);
        }
    };
    Some(match msg {
        BusMessage::Nmt { command, node } => {
            let what = if command == 0x01 { "start".to_string() } else { format!("command {command:#04x}") };
            let target = if node == 0 { "all nodes".to_string() } else { format!("node {node}") };
            BusFrame::new("nmt", format!("NMT {what} {target}"))
        }
        BusMessage::Command { node, data } => {
            let mut i = match table::decode_command(&data) {
                Ok(d) => {
                    let mut i = BusFrame::new("command", format!("{} {}", d.def.key, fields_text(&d.fields)));
                    i.module = Some(match d.address {
                        Address::Module(m) => m.get(),
                        Address::Controller => 0xFF,
                    });
                    i.details = json!({"command": d.def.key, "selector": d.selector, "fields": d.fields});
                    i
                }
                Err(e) => {
                    let mut i = BusFrame::new("command", format!("{:02x?}", data));
                    i.error = Some(e.to_string());
                    i
                }
            };
            i.node = Some(node.get());
            i
        }
        BusMessage::Answer(a) => {
            let kind = match a.kind {
                AnswerKind::Reply => "reply",
                AnswerKind::Event => "event",
                AnswerKind::Error => "error",
            };
            let mut i = BusFrame::new(kind, String::new());
            i.node = Some(a.node.get());
            i.module = Some(a.module);
            if let Some(err) = a.error() {
                i.summary = format!("error to {:#04x}: {}", a.command, err.describe());
                i.details = json!({"command": a.command, "general": err.general, "status1": err.status1, "status2": err.status2});
            } else if let Some(r) = a.reply() {
                match r {
                    Ok(r) => {
                        i.summary = format!("{} {}", r.def.map_or("?", |d| d.key), fields_text(&r.fields));
                        i.details = serde_json::to_value(&r).unwrap_or_default();
                    }
                    Err(e) => i.error = Some(e.to_string()),
                }
            }
            i
        }
    })
}

fn fields_text(fields: &[table::FieldValue]) -> String {
    fields
        .iter()
        .map(|f| match (f.value, f.value_unit) {
            (Some(v), Some(u)) => format!("{}={v}{u}", f.key),
            _ => format!("{}={}", f.key, f.raw),
        })
        .collect::<Vec<_>>()
        .join(" ")
}

/// An answer as another 6168 module of the node sends it, its module
/// picked by `other(current, lowest, highest)`; `None` for a frame that is
/// no module's answer. What the simulator's `wrong-module` fault sends.
pub fn readdressed(f: &CanFrame, other: &mut dyn FnMut(u8, u8, u8) -> u8) -> Option<CanFrame> {
    if transport::answer_node(f).is_none() || f.data().len() < 2 || f.data()[1] > 15 {
        return None;
    }
    let mut data = f.data().to_vec();
    data[1] = other(data[1], 0, 15);
    CanFrame::new(f.id(), &data)
}
