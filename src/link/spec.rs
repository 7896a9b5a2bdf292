//! `--link` URIs: `socketcan:IFACE`, `slcan:TTY[?bitrate=N]`,
//! `socketcand:HOST[:PORT]/BUS[?rtt=MS]`, `serial:TTY[?baud=N&format=F]`, `sim`.

use std::fmt;
use std::time::Duration;

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
    /// A bus of a socketcand daemon on another host, in raw mode. `rtt`:
    /// the round trip the answer timeouts allow for; `None` measures it at
    /// the open.
    Socketcand {
        host: String,
        port: u16,
        bus: String,
        rtt: Option<Duration>,
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
        matches!(self, Self::SocketCan { .. } | Self::Slcan { .. } | Self::Socketcand { .. } | Self::Sim(_))
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
        let (scheme, rest) = uri.split_once(':').ok_or_else(|| {
            SpecError(format!("{uri:?}: expected socketcan:IFACE, slcan:TTY, socketcand:HOST/BUS, serial:TTY or sim"))
        })?;
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
            "socketcand" => {
                let mut rtt = None;
                for (k, v) in params {
                    match k {
                        "rtt" => {
                            let ms = number(k, v)?;
                            if ms > MAX_RTT_MS {
                                return Err(SpecError(format!("{uri:?}: rtt {ms} ms out of range 0 to {MAX_RTT_MS}")));
                            }
                            rtt = Some(Duration::from_millis(ms.into()))
                        }
                        _ => return Err(unknown(k)),
                    }
                }
                let (host, port, bus) = socketcand_address(path).map_err(|why| SpecError(format!("{uri:?}: {why}")))?;
                Ok(Self::Socketcand { host, port, bus, rtt })
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
            _ => Err(SpecError(format!(
                "{uri:?}: unknown link type {scheme:?} (socketcan, slcan, socketcand, serial or sim)"
            ))),
        }
    }
}

/// socketcand's own default port.
pub const SOCKETCAND_PORT: u16 = 29536;
/// The largest `rtt=` taken, in ms: a round trip longer than that is no
/// link to drive motion over.
const MAX_RTT_MS: u32 = 10_000;

/// `HOST[:PORT]/BUS`, an IPv6 address in brackets (`[::1]:29536/can0`).
fn socketcand_address(path: &str) -> Result<(String, u16, String), String> {
    let (hostport, bus) =
        path.split_once('/').ok_or("expected socketcand:HOST[:PORT]/BUS, e.g. socketcand:10.0.0.7:29536/can0")?;
    // The daemon reads the name up to a blank or `>`, at most 16 characters.
    if bus.is_empty() || bus.len() > 16 || !bus.bytes().all(|b| b.is_ascii_graphic() && b != b'<' && b != b'>') {
        return Err(format!("bus name {bus:?}: 1 to 16 characters, no blanks, < or >"));
    }
    let (host, port) = if let Some(v6) = hostport.strip_prefix('[') {
        let (host, after) = v6.split_once(']').ok_or("an IPv6 address ends with ]")?;
        match after {
            "" => (host, None),
            _ => (host, Some(after.strip_prefix(':').ok_or("expected :PORT after ]")?)),
        }
    } else {
        match hostport.split_once(':') {
            Some((h, _)) if h.contains(':') || hostport.matches(':').count() > 1 => {
                return Err("an IPv6 address goes in brackets: socketcand:[::1]:29536/can0".into())
            }
            Some((h, p)) => (h, Some(p)),
            None => (hostport, None),
        }
    };
    if host.is_empty() || host.contains(char::is_whitespace) {
        return Err("missing host before /BUS".into());
    }
    // A name or an address: printable ASCII, brackets only around an IPv6
    // address (the spec prints back as it was read).
    if !host.bytes().all(|b| b.is_ascii_graphic() && b != b'[' && b != b']') {
        return Err(format!("host {host:?}: a name or an address (an IPv6 address in brackets)"));
    }
    let port = match port {
        None => SOCKETCAND_PORT,
        Some(p) => match p.parse::<u16>() {
            Ok(n) if n > 0 => n,
            _ => return Err(format!("port {p:?} is not 1 to 65535")),
        },
    };
    Ok((host.to_string(), port, bus.to_string()))
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
            Self::Socketcand { host, port, bus, rtt } => {
                if host.contains(':') {
                    write!(f, "socketcand:[{host}]:{port}/{bus}")?;
                } else {
                    write!(f, "socketcand:{host}:{port}/{bus}")?;
                }
                match rtt {
                    Some(r) => write!(f, "?rtt={}", r.as_millis()),
                    None => Ok(()),
                }
            }
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
            "socketcand:host",
            "socketcand:/can0",
            "socketcand:h:0/can0",
            "socketcand:h:70000/can0",
            "socketcand:h:x/can0",
            "socketcand:h/",
            "socketcand:h/can 0",
            "socketcand:h/a>b",
            // Found by the link_uri fuzz target: it printed back as another spec.
            "socketcand:[[\u{1d}\u{0}1]//dev40",
            "socketcand:h\u{7}st/can0",
            "socketcand:::1/can0",
            "socketcand:[::1/can0",
            "socketcand:h/can0?rtt=x",
            "socketcand:h/can0?rtt=10001",
            "socketcand:h/can0?bitrate=5",
        ] {
            assert!(bad.parse::<LinkSpec>().is_err(), "{bad}");
        }
    }

    #[test]
    fn socketcand_links_parse_and_print_with_their_port() {
        let sc =
            |host: &str, port, bus: &str, rtt| LinkSpec::Socketcand { host: host.into(), port, bus: bus.into(), rtt };
        for (text, spec, shown) in [
            ("socketcand:10.0.0.7:29536/can0", sc("10.0.0.7", 29536, "can0", None), "socketcand:10.0.0.7:29536/can0"),
            ("socketcand:cell4/can1", sc("cell4", SOCKETCAND_PORT, "can1", None), "socketcand:cell4:29536/can1"),
            ("socketcand:[::1]:4000/vcan0", sc("::1", 4000, "vcan0", None), "socketcand:[::1]:4000/vcan0"),
            (
                "socketcand:[fe80::1]/can0",
                sc("fe80::1", SOCKETCAND_PORT, "can0", None),
                "socketcand:[fe80::1]:29536/can0",
            ),
            (
                "socketcand:h:1/can0?rtt=40",
                sc("h", 1, "can0", Some(Duration::from_millis(40))),
                "socketcand:h:1/can0?rtt=40",
            ),
        ] {
            assert_eq!(text.parse(), Ok(spec.clone()), "{text}");
            assert_eq!(spec.to_string(), shown);
            assert_eq!(shown.parse(), Ok(spec), "{shown}");
        }
        let e = "socketcand:::1/can0".parse::<LinkSpec>().unwrap_err();
        assert!(e.to_string().contains("brackets"), "{e}");
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
