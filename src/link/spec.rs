//! `--link` URIs: `socketcan:IFACE`, `slcan:TTY[?bitrate=N]`,
//! `serial:TTY[?baud=N&format=F]`, `sim`.

use std::fmt;

use crate::proto::slcan::SLCAN_BITRATES;

/// Serial character format.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SerialFormat {
    F8N1,
    F7N1,
    F7E1,
    F7O1,
}

impl SerialFormat {
    pub fn data_bits(self) -> u8 {
        if self == Self::F8N1 {
            8
        } else {
            7
        }
    }

    /// Bits on the wire per character: start + data + parity + stop.
    pub fn bits_per_char(self) -> u32 {
        match self {
            Self::F8N1 => 10,
            Self::F7N1 => 9,
            Self::F7E1 | Self::F7O1 => 10,
        }
    }
}

impl std::str::FromStr for SerialFormat {
    type Err = SpecError;
    fn from_str(s: &str) -> Result<Self, SpecError> {
        match s.to_ascii_uppercase().as_str() {
            "8N1" => Ok(Self::F8N1),
            "7N1" => Ok(Self::F7N1),
            "7E1" => Ok(Self::F7E1),
            "7O1" => Ok(Self::F7O1),
            _ => Err(SpecError(format!("unknown serial format {s:?} (expected 8N1, 7N1, 7E1 or 7O1)"))),
        }
    }
}

impl fmt::Display for SerialFormat {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Self::F8N1 => "8N1",
            Self::F7N1 => "7N1",
            Self::F7E1 => "7E1",
            Self::F7O1 => "7O1",
        })
    }
}

#[derive(Debug, Clone, PartialEq, Eq)]
pub enum LinkSpec {
    SocketCan {
        iface: String,
    },
    Slcan {
        path: String,
        bitrate: u32,
    },
    /// `baud` / `format` `None` means the device family's default.
    Serial {
        path: String,
        baud: Option<u32>,
        format: Option<SerialFormat>,
    },
    /// The in-process bench, in the state it starts in.
    Sim(SimStart),
}

/// How the in-process bench starts (`sim?pac=online&cdios=enabled`): what a
/// technician would have done by hand first, so that a command that needs
/// it can be tried on its own (each command gets a fresh bench).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash)]
pub struct SimStart {
    pub pac: PacStart,
    /// The Cdios node started and every motor enabled.
    pub cdios_enabled: bool,
}

#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("bad link {0}")]
pub struct SpecError(pub String);

impl LinkSpec {
    pub fn is_can(&self) -> bool {
        matches!(self, Self::SocketCan { .. } | Self::Slcan { .. } | Self::Sim(_))
    }
}

impl std::str::FromStr for LinkSpec {
    type Err = SpecError;

    fn from_str(uri: &str) -> Result<Self, SpecError> {
        if uri == "sim" {
            return Ok(Self::Sim(SimStart::default()));
        }
        if let Some(query) = uri.strip_prefix("sim?") {
            return sim_start(uri, query).map(Self::Sim);
        }
        let (scheme, rest) = uri
            .split_once(':')
            .ok_or_else(|| SpecError(format!("{uri:?}: expected socketcan:IFACE, slcan:TTY, serial:TTY or sim")))?;
        let (path, query) = rest.split_once('?').unwrap_or((rest, ""));
        if path.is_empty() {
            return Err(SpecError(format!("{uri:?}: missing device after {scheme}:")));
        }
        let mut params = Vec::new();
        for pair in query.split('&').filter(|p| !p.is_empty()) {
            let (k, v) =
                pair.split_once('=').ok_or_else(|| SpecError(format!("{uri:?}: {pair:?} is not key=value")))?;
            params.push((k, v));
        }
        let number = |k: &str, v: &str| -> Result<u32, SpecError> {
            v.parse().map_err(|_| SpecError(format!("{uri:?}: {k}={v:?} is not a number")))
        };
        let unknown = |k: &str| SpecError(format!("{uri:?}: unknown option {k:?} for {scheme}:"));
        match scheme {
            "socketcan" => {
                if let Some((k, _)) = params.first() {
                    return Err(unknown(k));
                }
                if path.len() > 15 {
                    return Err(SpecError(format!("{uri:?}: interface name longer than 15 characters")));
                }
                Ok(Self::SocketCan { iface: path.into() })
            }
            "slcan" => {
                let mut bitrate = 1_000_000;
                for (k, v) in params {
                    match k {
                        "bitrate" => bitrate = number(k, v)?,
                        _ => return Err(unknown(k)),
                    }
                }
                if !SLCAN_BITRATES.contains(&bitrate) {
                    return Err(SpecError(format!(
                        "{uri:?}: bitrate {bitrate} is not one of slcan's S0..S8 {SLCAN_BITRATES:?}"
                    )));
                }
                Ok(Self::Slcan { path: path.into(), bitrate })
            }
            "serial" => {
                let (mut baud, mut format) = (None, None);
                for (k, v) in params {
                    match k {
                        "baud" => {
                            let b = number(k, v)?;
                            if !(300..=4_000_000).contains(&b) {
                                return Err(SpecError(format!("{uri:?}: baud {b} out of range 300 to 4000000")));
                            }
                            baud = Some(b)
                        }
                        "format" => format = Some(v.parse()?),
                        _ => return Err(unknown(k)),
                    }
                }
                Ok(Self::Serial { path: path.into(), baud, format })
            }
            "sim" => Err(SpecError(format!(
                "{uri:?}: the simulated bench takes no path: --link sim, or sim?pac=online&cdios=enabled"
            ))),
            _ => Err(SpecError(format!("{uri:?}: unknown link type {scheme:?} (socketcan, slcan, serial or sim)"))),
        }
    }
}

/// The PA-CONTROL's mode when the in-process bench starts.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash)]
pub enum PacStart {
    /// Home position, as after power-up.
    #[default]
    Home,
    /// Online mode with every axis referenced (0603, then 0A83 per axis).
    Online,
    /// Automatic mode started from home position (0602).
    Automatic,
}

/// `pac=online|automatic`, `cdios=enabled`, joined with `&`.
fn sim_start(uri: &str, query: &str) -> Result<SimStart, SpecError> {
    let mut start = SimStart::default();
    for pair in query.split('&') {
        match pair {
            "pac=online" => start.pac = PacStart::Online,
            "pac=automatic" => start.pac = PacStart::Automatic,
            "cdios=enabled" => start.cdios_enabled = true,
            _ => {
                return Err(SpecError(format!(
                "{uri:?}: {pair:?} is no start state of the simulated bench (pac=online, pac=automatic, cdios=enabled)"
            )))
            }
        }
    }
    Ok(start)
}

impl fmt::Display for LinkSpec {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::SocketCan { iface } => write!(f, "socketcan:{iface}"),
            Self::Slcan { path, bitrate } => write!(f, "slcan:{path}?bitrate={bitrate}"),
            Self::Serial { path, baud, format } => {
                write!(f, "serial:{path}")?;
                let mut sep = '?';
                if let Some(b) = baud {
                    write!(f, "{sep}baud={b}")?;
                    sep = '&';
                }
                if let Some(fm) = format {
                    write!(f, "{sep}format={fm}")?;
                }
                Ok(())
            }
            Self::Sim(start) => {
                f.write_str("sim")?;
                let mut sep = '?';
                match start.pac {
                    PacStart::Home => {}
                    PacStart::Online => {
                        write!(f, "{sep}pac=online")?;
                        sep = '&';
                    }
                    PacStart::Automatic => {
                        write!(f, "{sep}pac=automatic")?;
                        sep = '&';
                    }
                }
                if start.cdios_enabled {
                    write!(f, "{sep}cdios=enabled")?;
                }
                Ok(())
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_every_form() {
        assert_eq!("sim".parse(), Ok(LinkSpec::Sim(SimStart::default())));
        let both = SimStart { pac: PacStart::Online, cdios_enabled: true };
        assert_eq!("sim?pac=online&cdios=enabled".parse(), Ok(LinkSpec::Sim(both)));
        assert_eq!(LinkSpec::Sim(both).to_string(), "sim?pac=online&cdios=enabled");
        assert_eq!("sim?cdios=enabled".parse::<LinkSpec>().unwrap().to_string(), "sim?cdios=enabled");
        assert_eq!("sim?pac=automatic".parse::<LinkSpec>().unwrap().to_string(), "sim?pac=automatic");
        assert_eq!("socketcan:can0".parse(), Ok(LinkSpec::SocketCan { iface: "can0".into() }));
        assert_eq!(
            "slcan:/dev/ttyACM0".parse(),
            Ok(LinkSpec::Slcan { path: "/dev/ttyACM0".into(), bitrate: 1_000_000 })
        );
        assert_eq!(
            "slcan:/dev/ttyACM0?bitrate=500000".parse(),
            Ok(LinkSpec::Slcan { path: "/dev/ttyACM0".into(), bitrate: 500_000 })
        );
        assert_eq!(
            "serial:/dev/pts/8?baud=9600&format=7N1".parse(),
            Ok(LinkSpec::Serial { path: "/dev/pts/8".into(), baud: Some(9600), format: Some(SerialFormat::F7N1) })
        );
        let s: LinkSpec = "serial:/dev/pts/8?baud=9600&format=7N1".parse().unwrap();
        assert_eq!(s.to_string(), "serial:/dev/pts/8?baud=9600&format=7N1");
    }

    #[test]
    fn rejects_bad_uris() {
        for bad in [
            "",
            "can0",
            "socketcan:",
            "slcan:/dev/x?bitrate=123",
            "serial:/dev/x?baud=abc",
            "serial:/dev/x?format=9N2",
            "serial:/dev/x?speed=1",
            "usb:/dev/x",
            "socketcan:a?x=1",
        ] {
            assert!(bad.parse::<LinkSpec>().is_err(), "{bad}");
        }
    }

    #[test]
    fn a_sim_with_a_path_is_told_how_sim_is_written() {
        let e = "sim:x".parse::<LinkSpec>().unwrap_err();
        assert_eq!(
            e.to_string(),
            "bad link \"sim:x\": the simulated bench takes no path: --link sim, or sim?pac=online&cdios=enabled"
        );
        assert!("sim?pac=offline".parse::<LinkSpec>().is_err());
        assert!("sim?".parse::<LinkSpec>().is_err());
    }
}
