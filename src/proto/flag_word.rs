//! Flag words as data: a word is a table of named single-bit flags, each
//! with a class (error, warning, info, obsolete), decoded from a raw value
//! and parsed from names. The tables themselves are the families' (the
//! PowerCube's CubeState, Config, ... in `proto::powercube::flags`); what
//! prints or decodes a word works on any of them.

/// How a flag is to be read.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum FlagClass {
    /// The manual's "[These flags describe an error status]".
    Error,
    /// Not an error, but something the operator should look at (the manual
    /// calls STATE_CURLIMIT "a warning").
    Warning,
    /// The manual's "[These flags provide useful information on the module status]".
    Info,
    /// The manual's "[These flags are obsolete]" and Setup bits marked "not used".
    Obsolete,
}

impl FlagClass {
    /// The name in JSON and on screen (the serde name).
    pub const fn name(self) -> &'static str {
        match self {
            Self::Error => "error",
            Self::Warning => "warning",
            Self::Info => "info",
            Self::Obsolete => "obsolete",
        }
    }
}

/// One flag of a word.
#[derive(Debug, PartialEq, Eq)]
pub struct FlagDef {
    /// The manual's name, e.g. `STATE_HOME_OK`.
    pub name: &'static str,
    /// A single bit.
    pub mask: u32,
    pub class: FlagClass,
    /// Short lower-case form for the command line, e.g. `brake-present`.
    pub short: Option<&'static str>,
    /// The manual's explanation.
    pub description: &'static str,
}

/// A flag word: a table of [`FlagDef`]s and the width of the word.
#[derive(Debug)]
pub struct FlagWord {
    /// Key for the command line, e.g. `cube-state`.
    pub kind: &'static str,
    /// Human name, e.g. `CubeState`.
    pub name: &'static str,
    /// Width in bits: 8, 16 or 32.
    pub bits: u8,
    pub flags: &'static [FlagDef],
}

/// A raw word taken apart.
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize)]
pub struct Decoded {
    pub raw: u32,
    /// Names of all set flags, in bit order; a bit with two names gives both.
    pub flags: Vec<&'static str>,
    /// The [`FlagClass::Error`] flags among `flags`.
    pub errors: Vec<&'static str>,
    /// The [`FlagClass::Warning`] flags among `flags`.
    pub warnings: Vec<&'static str>,
    /// Set bits no flag of the word names (including bits beyond its width).
    pub unknown_bits: u32,
}

impl Decoded {
    /// Whether any error flag is set.
    pub fn has_error(&self) -> bool {
        !self.errors.is_empty()
    }
}

impl std::fmt::Display for Decoded {
    /// `0x00000003 STATE_ERROR|STATE_HOME_OK`, plus `unknown 0x...` where
    /// unnamed bits are set.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{:#010x}", self.raw)?;
        if !self.flags.is_empty() {
            write!(f, " {}", self.flags.join("|"))?;
        }
        if self.unknown_bits != 0 {
            write!(f, " unknown {:#010x}", self.unknown_bits)?;
        }
        Ok(())
    }
}

/// Why flag text could not be turned into a mask.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum FlagParseError {
    #[error("{word} has no flag {name:?}")]
    UnknownFlag { word: &'static str, name: String },
    #[error("{text:?} does not fit the {bits}-bit {word} word")]
    TooWide { word: &'static str, bits: u8, text: String },
}

impl FlagWord {
    /// Every bit the word can hold.
    pub const fn width_mask(&self) -> u32 {
        if self.bits >= 32 {
            u32::MAX
        } else {
            (1u32 << self.bits) - 1
        }
    }

    /// The union of all named bits.
    pub fn known_mask(&self) -> u32 {
        self.flags.iter().fold(0, |m, d| m | d.mask)
    }

    /// The flags set in `raw`, in table order.
    pub fn set_flags(&self, raw: u32) -> impl Iterator<Item = &'static FlagDef> {
        self.flags.iter().filter(move |d| raw & d.mask != 0)
    }

    /// Takes `raw` apart.
    pub fn decode(&self, raw: u32) -> Decoded {
        let set: Vec<&'static FlagDef> = self.set_flags(raw).collect();
        let names_of = |class: Option<FlagClass>| {
            set.iter().filter(|d| class.is_none_or(|c| d.class == c)).map(|d| d.name).collect::<Vec<_>>()
        };
        Decoded {
            raw,
            flags: names_of(None),
            errors: names_of(Some(FlagClass::Error)),
            warnings: names_of(Some(FlagClass::Warning)),
            unknown_bits: raw & !self.known_mask(),
        }
    }

    /// `raw` in the one `state` shape of the JSON output (docs/json.md): the
    /// decoded names, each set flag explained, the bits no flag names.
    pub fn state_json(&self, raw: u32) -> serde_json::Value {
        let d = self.decode(raw);
        let details: Vec<_> = self
            .set_flags(raw)
            .map(|f| serde_json::json!({"name": f.name, "mask": f.mask, "class": f.class.name(), "description": f.description}))
            .collect();
        serde_json::json!({"raw": raw, "flags": d.flags, "errors": d.errors, "warnings": d.warnings,
                           "details": details, "unknown_bits": d.unknown_bits})
    }

    /// The flag called `name` (manual name or short form, any case).
    pub fn flag(&self, name: &str) -> Option<&'static FlagDef> {
        let name = name.trim();
        self.flags
            .iter()
            .find(|d| d.name.eq_ignore_ascii_case(name) || d.short.is_some_and(|s| s.eq_ignore_ascii_case(name)))
    }

    /// A number (decimal, `0x`, `0b`) or flag names joined by `|`, `,` or
    /// `+`, as a raw word.
    pub fn parse(&self, text: &str) -> Result<u32, FlagParseError> {
        let t = text.trim();
        if let Some(v) = super::parse_int(t) {
            return u32::try_from(v)
                .ok()
                .filter(|v| v & !self.width_mask() == 0)
                .ok_or_else(|| FlagParseError::TooWide { word: self.name, bits: self.bits, text: text.into() });
        }
        t.split(['|', ',', '+']).filter(|s| !s.trim().is_empty()).try_fold(0u32, |acc, part| {
            self.flag(part)
                .map(|d| acc | d.mask)
                .ok_or_else(|| FlagParseError::UnknownFlag { word: self.name, name: part.trim().into() })
        })
    }
}
