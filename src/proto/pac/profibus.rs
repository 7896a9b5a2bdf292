//! Decoders for the PA-CONTROL's Profibus-DP / Interbus-S words (manual
//! chapter 2, and 4.2 for Interbus-S, which uses the same CMD layout) and for
//! the status dates of 1910 / 1911 / 1921.
//!
//! A PC does not act as that bus master; these decoders exist so that values
//! seen on a PLC or in WINPAC's diagnosis windows can be read
//! (`axisctl decode KIND VALUE`). Words are big-endian ("high byte" first)
//! and an 8-byte image is read as one u64, PAC byte 0 most significant.
//!
//! Every word is one [`WordDef`] row listing its fields; [`decode`] turns a
//! raw value into a serialisable [`Decoded`].

use serde::Serialize;

use super::table;

/// How a field's value reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum FieldKind {
    /// One bit; 1 means what the name says.
    Flag,
    /// A bit or byte whose 0 and 1 mean the given texts (other values:
    /// undefined).
    Text { zero: &'static str, one: &'static str },
    /// A plain number.
    Number,
    /// A 32-bit command / acknowledge date: integer and IEEE float readings.
    Date32,
    /// Operating status code (manual 6.4).
    OperatingStatus,
    /// Command error number (manual 6.5).
    CommandError,
    /// Command code (chapter 5).
    CommandCode,
    /// Axis status as 1910.
    AxisStatus,
    /// Bit n = axis n+1 moving (1911).
    AxisBitmap,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct Field {
    pub name: &'static str,
    /// Lowest bit.
    pub lsb: u8,
    pub width: u8,
    pub kind: FieldKind,
    pub description: &'static str,
}

const fn flag(bit: u8, name: &'static str, description: &'static str) -> Field {
    Field { name, lsb: bit, width: 1, kind: FieldKind::Flag, description }
}

const fn text(lsb: u8, width: u8, name: &'static str, zero: &'static str, one: &'static str) -> Field {
    Field { name, lsb, width, kind: FieldKind::Text { zero, one }, description: "" }
}

const fn field(lsb: u8, width: u8, name: &'static str, kind: FieldKind, description: &'static str) -> Field {
    Field { name, lsb, width, kind, description }
}

/// One decodable word.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct WordDef {
    /// The KIND of `axisctl decode KIND VALUE`.
    pub kind: &'static str,
    pub title: &'static str,
    pub section: &'static str,
    /// Width of the raw value in bits.
    pub bits: u8,
    pub fields: &'static [Field],
}

const CMD_STATUS_FIELDS: &[Field] = &[
    flag(15, "RF", "receive flag: equals the master's SEND flag once the command was recognised"),
    flag(14, "KF", "command error flag: see the command error number"),
    flag(13, "BF", "end of processing flag"),
    field(0, 13, "command_error", FieldKind::CommandError, "command error number (6.5)"),
];

const CMD_OPSTATE_FIELDS: &[Field] = &[
    flag(15, "FE", "error in the PA-CONTROL: read it with 1909"),
    field(0, 8, "operating_status", FieldKind::OperatingStatus, "operating status (6.4)"),
];

const CMD_CODE_FIELDS: &[Field] = &[
    flag(15, "SF", "send flag: toggled by the master when a new command is ready"),
    field(0, 15, "command_code", FieldKind::CommandCode, "command code"),
];

const CMD_REQUEST_FIELDS: &[Field] = &[
    field(32, 32, "command_date", FieldKind::Date32, "32-bit command date (words 0-1)"),
    field(16, 16, "command_parameter", FieldKind::Number, "16-bit command parameter (word 2)"),
    flag(15, "SF", "send flag: toggled by the master when a new command is ready"),
    field(0, 15, "command_code", FieldKind::CommandCode, "command code"),
];

const CMD_REPLY_FIELDS: &[Field] = &[
    field(32, 32, "ack_date", FieldKind::Date32, "32-bit acknowledge date (words 0-1)"),
    flag(31, "FE", "error in the PA-CONTROL: read it with 1909"),
    field(16, 8, "operating_status", FieldKind::OperatingStatus, "operating status (6.4)"),
    flag(15, "RF", "receive flag: equals the master's SEND flag once the command was recognised"),
    flag(14, "KF", "command error flag: see the command error number"),
    flag(13, "BF", "end of processing flag"),
    field(0, 13, "command_error", FieldKind::CommandError, "command error number (6.5)"),
];

const CTRL_CONTROL_FIELDS: &[Field] = &[
    flag(15, "integer_positions", "axis positions and R registers as integers (value * 1000), else IEEE float"),
    flag(4, "start_online", "start ONLINE"),
    flag(3, "automatic_start", "AUTOMATIC START"),
    text(2, 1, "cancel", "cancel requested (low active)", "no cancel"),
    text(1, 1, "stop", "stop requested (low active)", "no stop"),
    text(0, 1, "error_reset", "error reset requested (low active)", "no error reset"),
];

const CTRL_STATUS_FIELDS: &[Field] = &[
    flag(15, "integer_positions", "axis positions and R registers are treated as integers"),
    flag(11, "online_stopped", "ONLINE stopped"),
    flag(10, "online_active", "ONLINE active"),
    flag(9, "automatic_stopped", "AUTOMATIC stopped"),
    flag(8, "automatic_active", "AUTOMATIC active"),
    flag(2, "system_error", "system error"),
    flag(1, "battery_ok", "battery o.k."),
    flag(0, "control_ready", "control ready"),
];

// Manual 2.7.1 prints "G29.[position]" for both bits 4 and 5; the
// explanations 2.7.3.4 / 2.7.3.5 (in bit order) make bit 4 G26.
const AXIS_CONTROL_FIELDS: &[Field] = &[
    flag(17, "disable_limit_switch_monitoring", "disable monitoring of limit switches, G142 (MP, PLS 6/7/8 only)"),
    flag(16, "reset_axis_error", "reset axis error"),
    flag(15, "traverse_to_min", "traverse up to min. traverse range"),
    flag(14, "traverse_to_max", "traverse up to max. traverse range"),
    flag(13, "reset_displaced_flags", "reset flag and group flag \"axis was moved in OFF status\""),
    flag(12, "delete_g29_offsets", "delete G29 offset(s)"),
    flag(11, "traverse_negative", "traverse in negative direction without reference and range check"),
    flag(10, "traverse_positive", "traverse in positive direction without reference and range check"),
    flag(9, "while_input_0", "traverse (relative/absolute) as long as the input is 0 (G123 Ix..0)"),
    flag(8, "while_input_1", "traverse (relative/absolute) as long as the input is 1 (G123 Ix..1)"),
    flag(7, "relative", "relative traversing to the position"),
    flag(6, "absolute", "absolute traversing to the position"),
    flag(5, "g29", "G29: set axis to position"),
    flag(4, "g26", "G26: set axis to position and reference"),
    flag(3, "g25", "G25: approach the reference point"),
    flag(2, "start", "start command (rising edge starts the traverse command)"),
    flag(1, "disable_drive", "disable DRIVE (G140 / G141)"),
    flag(0, "axis_on", "axis ON"),
];

const AXIS_STATUS_FIELDS: &[Field] = &[
    flag(15, "axis_error", "axis error: see the axis error number"),
    flag(14, "cmd_error", "a start command could not be carried out"),
    flag(13, "group_displaced", "an axis of the group was displaced in DRIVE-DISABLED state"),
    flag(12, "displaced", "displaced too much during DRIVE-DISABLED state"),
    flag(11, "stopped_by_g123", "stopped by a G123 action"),
    text(10, 1, "positive_limit_switch", "actuated", "not actuated"),
    text(9, 1, "negative_limit_switch", "actuated", "not actuated"),
    flag(8, "referenced", "axis is referenced"),
    flag(7, "active", "ACTIVE: a traversing task is being processed"),
    flag(6, "fault", "FAULT: drive error"),
    flag(5, "disabled", "DISABLED"),
    flag(4, "idle", "IDLE"),
    flag(3, "safe", "SAFE"),
    flag(2, "drive_disabled", "DRIVE DISABLED"),
    flag(1, "halt", "HALT"),
    flag(0, "drive_enabled", "DRIVE ENABLED"),
];

const EXT_AXIS_STATUS_FIELDS: &[Field] = &[
    text(24, 8, "power_pack", "not ready", "ready"),
    text(16, 8, "positive_limit_switch", "activated", "not activated"),
    text(8, 8, "negative_limit_switch", "activated", "not activated"),
    field(0, 8, "axis_status", FieldKind::AxisStatus, "axis status as 1910"),
];

const AXIS_STATUS_1910_FIELDS: &[Field] =
    &[field(0, 16, "axis_status", FieldKind::AxisStatus, "0 in position, 1 moving, 2 stopped, 4 fault, 8 measuring")];

const ALL_AXES_FIELDS: &[Field] =
    &[field(0, 16, "moving_axes", FieldKind::AxisBitmap, "bit n = axis n+1 moving, 0 = standing in position")];

/// Every decodable word.
pub const WORDS: &[WordDef] = &[
    WordDef {
        kind: "pac-cmd-status",
        title: "CMD interface reply word 3: RF / KF / BF and command error number",
        section: "2.4.2",
        bits: 16,
        fields: CMD_STATUS_FIELDS,
    },
    WordDef {
        kind: "pac-cmd-opstate",
        title: "CMD interface reply word 2: FE and operating status",
        section: "2.4.2",
        bits: 16,
        fields: CMD_OPSTATE_FIELDS,
    },
    WordDef {
        kind: "pac-cmd-code",
        title: "CMD interface request word 3: SF and command code",
        section: "2.4.1",
        bits: 16,
        fields: CMD_CODE_FIELDS,
    },
    WordDef {
        kind: "pac-cmd-request",
        title: "CMD interface, master to PA-CONTROL, all 8 bytes",
        section: "2.4.1",
        bits: 64,
        fields: CMD_REQUEST_FIELDS,
    },
    WordDef {
        kind: "pac-cmd-reply",
        title: "CMD interface, PA-CONTROL to master, all 8 bytes",
        section: "2.4.2",
        bits: 64,
        fields: CMD_REPLY_FIELDS,
    },
    WordDef {
        kind: "pac-ctrl-control",
        title: "CTRL interface control word (master to PA-CONTROL)",
        section: "2.5.1",
        bits: 16,
        fields: CTRL_CONTROL_FIELDS,
    },
    WordDef {
        kind: "pac-ctrl-status",
        title: "CTRL interface status word (PA-CONTROL to master)",
        section: "2.5.2",
        bits: 16,
        fields: CTRL_STATUS_FIELDS,
    },
    WordDef {
        kind: "pac-axis-control",
        title: "Module / axis interface: control word of the axis (online mode)",
        section: "2.7.1",
        bits: 32,
        fields: AXIS_CONTROL_FIELDS,
    },
    WordDef {
        kind: "pac-axis-status",
        title: "Module / axis interface: status word of the axis (online mode)",
        section: "2.7.2",
        bits: 32,
        fields: AXIS_STATUS_FIELDS,
    },
    WordDef {
        kind: "pac-ext-axis-status",
        title: "Extended axis status (1921 acknowledge date)",
        section: "5.2.4.28",
        bits: 32,
        fields: EXT_AXIS_STATUS_FIELDS,
    },
    WordDef {
        kind: "pac-axis-status-1910",
        title: "Axis status (1910 acknowledge date)",
        section: "5.2.4.22",
        bits: 16,
        fields: AXIS_STATUS_1910_FIELDS,
    },
    WordDef {
        kind: "pac-all-axes-1911",
        title: "Status of all axes (1911 acknowledge date)",
        section: "5.2.4.23",
        bits: 16,
        fields: ALL_AXES_FIELDS,
    },
];

pub fn word(kind: &str) -> Option<&'static WordDef> {
    WORDS.iter().find(|w| w.kind.eq_ignore_ascii_case(kind))
}

#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum WordError {
    #[error("unknown word kind {0:?}")]
    UnknownKind(String),
    #[error("{kind} is {bits} bits wide; {value:#x} does not fit")]
    TooWide { kind: &'static str, bits: u8, value: u64 },
}

/// One decoded field.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DecodedField {
    pub name: &'static str,
    /// "15" or "0-12".
    pub bits: String,
    pub value: u64,
    /// For one-bit flags: whether it is set.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub set: Option<bool>,
    /// What the value means, where there is more to say than the number.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub meaning: Option<String>,
    #[serde(skip_serializing_if = "str::is_empty")]
    pub description: &'static str,
}

/// A decoded word.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Decoded {
    pub kind: &'static str,
    pub title: &'static str,
    pub section: &'static str,
    pub raw: u64,
    pub fields: Vec<DecodedField>,
    /// Set bits no field describes (reserved / not used).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub reserved_bits_set: Vec<u8>,
}

impl Decoded {
    pub fn field(&self, name: &str) -> Option<&DecodedField> {
        self.fields.iter().find(|f| f.name == name)
    }
}

impl std::fmt::Display for Decoded {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(f, "{} = {:#x} ({}), manual {}", self.kind, self.raw, self.raw, self.section)?;
        writeln!(f, "{}", self.title)?;
        for fd in &self.fields {
            write!(f, "  bit {:>5}  {:<32} {}", fd.bits, fd.name, fd.value)?;
            if let Some(m) = &fd.meaning {
                write!(f, "  {m}")?;
            }
            writeln!(f)?;
        }
        if !self.reserved_bits_set.is_empty() {
            writeln!(f, "  reserved bits set: {:?}", self.reserved_bits_set)?;
        }
        Ok(())
    }
}

fn meaning(kind: FieldKind, value: u64) -> Option<String> {
    match kind {
        FieldKind::Flag | FieldKind::Number => None,
        FieldKind::Text { zero, one } => Some(match value {
            0 => zero.to_string(),
            1 => one.to_string(),
            _ => "undefined".to_string(),
        }),
        FieldKind::Date32 => {
            let v = value as u32;
            Some(format!("int {} / float {}", v as i32, f32::from_bits(v)))
        }
        FieldKind::OperatingStatus => Some(table::operating_status_text(value as u16).to_string()),
        FieldKind::CommandError => Some(match table::command_error(value as u16) {
            Some(d) => format!("{}: {}", d.label(), d.message),
            None => format!("0x{value:02X} ({value}): unknown command error"),
        }),
        FieldKind::CommandCode => Some(match table::command(value as u16) {
            Some(d) => format!("{:04X} {}", d.code, d.manual_name),
            None => format!("{value:04X} unknown command"),
        }),
        FieldKind::AxisStatus => Some(table::axis_status_text(value).to_string()),
        FieldKind::AxisBitmap => {
            let axes = table::moving_axes(value);
            Some(if axes.is_empty() {
                "no axis moving".to_string()
            } else {
                let list: Vec<_> = axes.iter().map(u8::to_string).collect();
                format!("moving: axes {}", list.join(", "))
            })
        }
    }
}

/// Decodes `raw` as the word `def`.
pub fn decode_word(def: &'static WordDef, raw: u64) -> Result<Decoded, WordError> {
    if def.bits < 64 && raw >> def.bits != 0 {
        return Err(WordError::TooWide { kind: def.kind, bits: def.bits, value: raw });
    }
    let mut covered = 0u64;
    let fields = def
        .fields
        .iter()
        .map(|fd| {
            let mask = if fd.width >= 64 { u64::MAX } else { (1u64 << fd.width) - 1 };
            covered |= mask << fd.lsb;
            let value = (raw >> fd.lsb) & mask;
            let bits = if fd.width == 1 { fd.lsb.to_string() } else { format!("{}-{}", fd.lsb, fd.lsb + fd.width - 1) };
            DecodedField {
                name: fd.name,
                bits,
                value,
                set: (fd.kind == FieldKind::Flag).then_some(value == 1),
                meaning: meaning(fd.kind, value),
                description: fd.description,
            }
        })
        .collect();
    let reserved_bits_set = (0..def.bits).filter(|b| raw >> b & 1 == 1 && covered >> b & 1 == 0).collect();
    Ok(Decoded { kind: def.kind, title: def.title, section: def.section, raw, fields, reserved_bits_set })
}

/// Decodes `raw` as the word named `kind` (one of [`WORDS`]).
pub fn decode(kind: &str, raw: u64) -> Result<Decoded, WordError> {
    let def = word(kind).ok_or_else(|| WordError::UnknownKind(kind.to_string()))?;
    decode_word(def, raw)
}

/// Reads an 8-byte CMD image as printed in the manual (PAC byte 0 first).
pub fn image(bytes: [u8; 8]) -> u64 {
    u64::from_be_bytes(bytes)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn value(d: &Decoded, name: &str) -> u64 {
        d.field(name).unwrap_or_else(|| panic!("no field {name}")).value
    }

    #[test]
    fn fields_do_not_overlap_and_fit() {
        for w in WORDS {
            let mut seen = 0u64;
            for f in w.fields {
                assert!(u32::from(f.lsb) + u32::from(f.width) <= u32::from(w.bits), "{} {}", w.kind, f.name);
                let mask = if f.width >= 64 { u64::MAX } else { ((1u64 << f.width) - 1) << f.lsb };
                assert_eq!(seen & mask, 0, "{} {}", w.kind, f.name);
                seen |= mask;
            }
        }
        for kind in [
            "pac-cmd-status",
            "pac-ctrl-control",
            "pac-ctrl-status",
            "pac-axis-control",
            "pac-axis-status",
            "pac-ext-axis-status",
            "pac-axis-status-1910",
        ] {
            assert!(word(kind).is_some(), "{kind}");
        }
    }

    // Manual 4.2.4 (Interbus-S, same CMD layout as 2.4): the master's images.
    #[test]
    fn manual_4_2_4_requests() {
        // "Get the status of input 5", SEND flag toggled to 1.
        let d = decode("pac-cmd-request", image([0x00, 0x00, 0x00, 0x00, 0x00, 0x05, 0x99, 0x00])).unwrap();
        assert_eq!(value(&d, "command_date"), 0);
        assert_eq!(value(&d, "command_parameter"), 5);
        assert_eq!(d.field("SF").unwrap().set, Some(true));
        assert_eq!(value(&d, "command_code"), 0x1900);
        assert_eq!(d.field("command_code").unwrap().meaning.as_deref(), Some("1900 cmd_get_single_input"));
        // "Describe integer register 3 with 333", SEND flag toggled to 1.
        let d = decode("pac-cmd-request", image([0x00, 0x00, 0x01, 0x4D, 0x00, 0x03, 0x89, 0x06])).unwrap();
        assert_eq!(value(&d, "command_date"), 333);
        assert_eq!(value(&d, "command_parameter"), 3);
        assert_eq!(value(&d, "SF"), 1);
        assert_eq!(value(&d, "command_code"), 0x0906);
        // Same command with SF = 0 (before the toggle): only word 3 differs.
        let d = decode("pac-cmd-code", 0x0906).unwrap();
        assert_eq!(d.field("SF").unwrap().set, Some(false));
        assert_eq!(value(&d, "command_code"), 0x0906);
    }

    // Manual 4.2.4: the PA-CONTROL's replies.
    #[test]
    fn manual_4_2_4_replies() {
        // Input 5 = 1, home position, RF = 1, BF = 1.
        let d = decode("pac-cmd-reply", image([0x00, 0x00, 0x00, 0x01, 0x00, 0x01, 0xA0, 0x00])).unwrap();
        assert_eq!(value(&d, "ack_date"), 1);
        assert_eq!(value(&d, "operating_status"), 1);
        assert_eq!(d.field("operating_status").unwrap().meaning.as_deref(), Some("home position"));
        assert_eq!(value(&d, "FE"), 0);
        assert_eq!((value(&d, "RF"), value(&d, "KF"), value(&d, "BF")), (1, 0, 1));
        assert_eq!(value(&d, "command_error"), 0);
        // N2 = 12345678.
        let d = decode("pac-cmd-reply", image([0x00, 0xBC, 0x61, 0x4E, 0x00, 0x01, 0x20, 0x00])).unwrap();
        assert_eq!(value(&d, "ack_date"), 12345678);
        // The manual prints word 3 of this and the R1 reply as 0200; with SF
        // toggled back to 0 the consistent value is 2000 (RF = 0, BF = 1).
        assert_eq!((value(&d, "RF"), value(&d, "BF")), (0, 1));
        // N3 := 333.
        let d = decode("pac-cmd-reply", image([0x00, 0x00, 0x01, 0x4D, 0x00, 0x01, 0xA0, 0x00])).unwrap();
        assert_eq!(value(&d, "ack_date"), 333);
        // "R1 = 640.0", printed as 4420 2000, which is IEEE 640.5 (640.0 is
        // 4420 0000): the decoder shows what the bits say.
        let d = decode("pac-cmd-reply", image([0x44, 0x20, 0x20, 0x00, 0x00, 0x01, 0x20, 0x00])).unwrap();
        assert_eq!(d.field("ack_date").unwrap().meaning.as_deref(), Some("int 1142956032 / float 640.5"));
    }

    // Manual 6.1 IEEE examples, through the Date32 reading. Three of the five
    // printed values are misprints of what the bits encode: 40160000 is
    // 2.34375 (printed 0.34375), 44202000 is 640.5 (printed 640.0), 44A80000
    // is 1344 (printed 20480, which is 46A00000).
    #[test]
    fn ieee_examples() {
        for (raw, expected) in [
            (0x4016_0000u64, "float 2.34375"),
            (0x4120_0000, "float 10"),
            (0x4348_0000, "float 200"),
            (0x4420_2000, "float 640.5"),
            (0x44A8_0000, "float 1344"),
        ] {
            let d = decode("pac-cmd-reply", raw << 32).unwrap();
            let m = d.field("ack_date").unwrap().meaning.clone().unwrap();
            assert!(m.ends_with(expected), "{raw:x}: {m}");
        }
    }

    #[test]
    fn cmd_status_word() {
        // Command error "unknown command" (13h), RF = 1, KF = 1.
        let d = decode("pac-cmd-status", 0xC013).unwrap();
        assert_eq!((value(&d, "RF"), value(&d, "KF"), value(&d, "BF")), (1, 1, 0));
        assert_eq!(d.field("command_error").unwrap().meaning.as_deref(), Some("0x13 (19): unknown command"));
        let d = decode("pac-cmd-opstate", 0x801F).unwrap();
        assert_eq!(value(&d, "FE"), 1);
        assert_eq!(d.field("operating_status").unwrap().meaning.as_deref(), Some("ONLINE"));
        assert_eq!(d.reserved_bits_set, Vec::<u8>::new());
        let d = decode("pac-cmd-opstate", 0x011F).unwrap();
        assert_eq!(d.reserved_bits_set, vec![8]);
    }

    #[test]
    fn ctrl_words() {
        // Stop, cancel and error reset are low active: all high = nothing requested.
        let d = decode("pac-ctrl-control", 0b1_0111).unwrap();
        assert_eq!(value(&d, "start_online"), 1);
        assert_eq!(d.field("stop").unwrap().meaning.as_deref(), Some("no stop"));
        let d = decode("pac-ctrl-control", 0).unwrap();
        assert_eq!(d.field("cancel").unwrap().meaning.as_deref(), Some("cancel requested (low active)"));
        let d = decode("pac-ctrl-status", 0x0403).unwrap();
        assert_eq!(d.field("online_active").unwrap().set, Some(true));
        assert_eq!(d.field("battery_ok").unwrap().set, Some(true));
        assert_eq!(d.field("control_ready").unwrap().set, Some(true));
        assert_eq!(d.field("system_error").unwrap().set, Some(false));
    }

    #[test]
    fn axis_words() {
        // Axis on + absolute + start.
        let d = decode("pac-axis-control", 0b100_0101).unwrap();
        assert_eq!((value(&d, "axis_on"), value(&d, "start"), value(&d, "absolute")), (1, 1, 1));
        assert_eq!(value(&d, "g26"), 0);
        let d = decode("pac-axis-control", 1 << 20).unwrap();
        assert_eq!(d.reserved_bits_set, vec![20]);
        // Drive enabled, referenced, both limit switches not actuated.
        let d = decode("pac-axis-status", 0x0701).unwrap();
        assert_eq!(value(&d, "drive_enabled"), 1);
        assert_eq!(value(&d, "referenced"), 1);
        assert_eq!(d.field("positive_limit_switch").unwrap().meaning.as_deref(), Some("not actuated"));
        assert_eq!(
            decode("pac-axis-status", 0x0001).unwrap().field("negative_limit_switch").unwrap().meaning.as_deref(),
            Some("actuated")
        );
    }

    // Manual 5.2.4.28: 16777476 = 0100 0104h.
    #[test]
    fn ext_axis_status_example() {
        let d = decode("pac-ext-axis-status", 16777476).unwrap();
        assert_eq!(d.field("power_pack").unwrap().meaning.as_deref(), Some("ready"));
        assert_eq!(d.field("positive_limit_switch").unwrap().meaning.as_deref(), Some("activated"));
        assert_eq!(d.field("negative_limit_switch").unwrap().meaning.as_deref(), Some("not activated"));
        assert_eq!(d.field("axis_status").unwrap().meaning.as_deref(), Some("axis standing still with malfunction"));
    }

    // Manual 5.2.4.22 (2 = stopped) and 5.2.4.23 (208 = axes 5, 7, 8).
    #[test]
    fn status_1910_1911_examples() {
        let d = decode("pac-axis-status-1910", 2).unwrap();
        assert_eq!(d.field("axis_status").unwrap().meaning.as_deref(), Some("axis standing still, was stopped"));
        let d = decode("pac-all-axes-1911", 208).unwrap();
        assert_eq!(d.field("moving_axes").unwrap().meaning.as_deref(), Some("moving: axes 5, 7, 8"));
    }

    #[test]
    fn errors_and_display() {
        assert_eq!(decode("nope", 0), Err(WordError::UnknownKind("nope".into())));
        assert_eq!(
            decode("pac-cmd-status", 0x1_0000),
            Err(WordError::TooWide { kind: "pac-cmd-status", bits: 16, value: 0x1_0000 })
        );
        let s = decode("PAC-CMD-STATUS", 0xA000).unwrap().to_string();
        assert!(s.contains("RF") && s.contains("no error"), "{s}");
        let json = serde_json::to_value(decode("pac-cmd-status", 0xA000).unwrap()).unwrap();
        assert_eq!(json["fields"][0]["name"], "RF");
        assert_eq!(json["fields"][0]["set"], true);
    }

    proptest::proptest! {
        #[test]
        fn decode_never_panics(raw in proptest::prelude::any::<u64>(), i in 0usize..WORDS.len()) {
            let w = &WORDS[i];
            match decode_word(w, raw) {
                Ok(d) => proptest::prop_assert_eq!(d.fields.len(), w.fields.len()),
                Err(WordError::TooWide { .. }) => proptest::prop_assert!(w.bits < 64 && raw >> w.bits != 0),
                Err(e) => proptest::prop_assert!(false, "{e}"),
            }
        }
    }
}
