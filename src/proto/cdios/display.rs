//! Commands and answers for humans (traces, error messages), by the
//! table's keys: `goto absolute position=5000`.

use std::fmt;

use super::session::Exchange;
use super::table::{self, DecodedCommand, FieldValue};
use super::transport::{Answer, AnswerKind};

/// ` key=raw` for each field, keys internal to the encoder left out.
struct Fields<'a>(&'a [FieldValue]);

impl fmt::Display for Fields<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        self.0.iter().filter(|v| !v.key.starts_with("key_")).try_for_each(|v| write!(f, " {}={}", v.key, v.raw))
    }
}

/// The row, the selector (unless the row has none) and the fields.
impl fmt::Display for DecodedCommand {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.def.key)?;
        if let Some(k) = self.def.selector(self.selector).map(|s| s.key).filter(|k| *k != "none") {
            write!(f, " {k}")?;
        }
        Fields(&self.fields).fmt(f)
    }
}

/// The command decoded, or its bytes when no row matches.
impl fmt::Display for Exchange {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match table::decode_command(&self.data) {
            Ok(d) => d.fmt(f),
            Err(_) => write!(f, "command {:02x?}", self.data),
        }
    }
}

/// A reply or event by its row and fields (`read_position
/// position=-1200`, `event read_status ...`), an error reply by its texts.
impl fmt::Display for Answer {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match (self.reply(), self.error()) {
            (Some(Ok(r)), _) => {
                if self.kind == AnswerKind::Event {
                    f.write_str("event ")?;
                }
                write!(f, "{}{}", r.def.map_or("unknown", |d| d.key), Fields(&r.fields))
            }
            (_, Some(e)) => f.write_str(&e.describe()),
            _ => write!(f, "{:02x?}", self.data),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::{Address, Command, GotoMode, ModuleId, NodeId};
    use super::*;
    use crate::proto::CanFrame;

    fn exchange(cmd: Command) -> Exchange {
        let address = Address::Module(ModuleId::new(1).unwrap());
        Exchange::new(NodeId::FACTORY, address, cmd.encode(address).unwrap())
    }

    fn answer(s: &str) -> Answer {
        Answer::from_frame(&s.parse::<CanFrame>().unwrap()).unwrap().unwrap()
    }

    #[test]
    fn commands_by_row_selector_and_fields() {
        // CLI contract: `cdios-goto -m 1 --node 1 5000` is 201#2301008813000000.
        let goto = exchange(Command::Goto { mode: GotoMode::Absolute, position: 5000 });
        assert_eq!(goto.frame().to_string(), "201#2301008813000000");
        assert_eq!(goto.to_string(), "goto absolute position=5000");
        assert_eq!(
            exchange(Command::Goto { mode: GotoMode::Relative, position: -5 }).to_string(),
            "goto relative position=-5"
        );
        assert_eq!(exchange(Command::StoreConfiguration { defaults: true }).to_string(), "store_configuration default");
        let odd = Exchange::new(NodeId::FACTORY, Address::Controller, [0x7F, 0, 0, 0, 0, 0, 0, 0]);
        assert_eq!(odd.to_string(), "command [7f, 00, 00, 00, 00, 00, 00, 00]");
    }

    #[test]
    fn answers_by_row_and_fields() {
        assert_eq!(answer("181#21000050FBFFFF00").to_string(), "read_position position=-1200");
        assert!(answer("181#6100007B00000000").to_string().starts_with("event read_position"));
        let err = answer("181#A307000100000000");
        assert_eq!(err.to_string(), err.error().unwrap().describe());
    }
}
