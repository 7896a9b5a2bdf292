//! Ids as typed: clap value parsers built from the family registry's
//! ranges (which are the proto newtypes' ranges), so a range is written once.

use axisctl::family::IdRange;

/// One id of `range`, e.g. a PowerCube module address. Its error says the
/// range in words (`"32" is not a valid module id 1 to 31`), which clap's
/// ranged parser would say as `1..=31`.
pub fn id(range: IdRange) -> impl Fn(&str) -> Result<u8, String> + Clone + Send + Sync + 'static {
    move |text| {
        let t = text.trim();
        t.parse::<u8>().ok().filter(|id| range.contains(*id)).ok_or_else(|| format!("{t:?} is not a valid {range}"))
    }
}

/// A whole number from `min` to `max` (`unit` after it in the error).
pub fn number<T>(
    min: T,
    max: T,
    unit: &'static str,
) -> impl Fn(&str) -> Result<T, String> + Clone + Send + Sync + 'static
where
    T: std::str::FromStr + PartialOrd + std::fmt::Display + Copy + Send + Sync + 'static,
{
    move |text| {
        let t = text.trim();
        let unit = if unit.is_empty() { String::new() } else { format!(" {unit}") };
        t.parse::<T>()
            .ok()
            .filter(|v| (min..=max).contains(v))
            .ok_or_else(|| format!("{t:?} is not a number from {min} to {max}{unit}"))
    }
}

/// A list of ids as typed: `3,5,17`, `1-8` or both; sorted, each once.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct IdList(pub Vec<u8>);

impl IdList {
    /// The ids as the proto newtype (`new` accepts every id of the list's range).
    pub fn to<T>(&self, new: impl Fn(u8) -> Option<T>) -> Vec<T> {
        self.0.iter().filter_map(|&id| new(id)).collect()
    }
}

/// The list as it would be typed, runs collapsed: `1-31`, `3,5,17`.
impl std::fmt::Display for IdList {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let mut i = 0;
        while i < self.0.len() {
            let start = self.0[i];
            let mut end = start;
            while i + 1 < self.0.len() && self.0[i + 1] == end + 1 {
                i += 1;
                end += 1;
            }
            if start != self.0[0] {
                f.write_str(",")?;
            }
            match end - start {
                0 => write!(f, "{start}")?,
                1 => write!(f, "{start},{end}")?,
                _ => write!(f, "{start}-{end}")?,
            }
            i += 1;
        }
        Ok(())
    }
}

/// Parses a list of ids of `range`; `allow_empty` for lists that may name none.
pub fn parse_list(text: &str, range: IdRange, allow_empty: bool) -> Result<IdList, String> {
    let mut out = Vec::new();
    for part in text.split(',').map(str::trim).filter(|p| !p.is_empty()) {
        let (a, b) = part.split_once('-').unwrap_or((part, part));
        let one = |s: &str| {
            let s = s.trim();
            let id = s.parse::<u8>().map_err(|_| format!("{s:?} is not a number"))?;
            if range.contains(id) {
                Ok(id)
            } else {
                Err(format!("{s:?} is not a valid {range}"))
            }
        };
        let (a, b) = (one(a)?, one(b)?);
        if a > b {
            return Err(format!("range {part:?} runs backwards"));
        }
        out.extend(a..=b);
    }
    out.sort_unstable();
    out.dedup();
    if out.is_empty() && !allow_empty {
        return Err(format!("the list names no {}", range.what));
    }
    Ok(IdList(out))
}

/// The devices a read command is asked about: one id (one JSON object),
/// a list such as `3,5,17` or `1-8`, or `all`, every device the link has
/// (a `{"devices": [...]}` document either way): the shape follows what
/// was typed, never how many answered.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Devices {
    One(u8),
    List(IdList),
    All,
}

/// As typed: `17`, `3,5,17`, `all` (clap shows a default this way).
impl std::fmt::Display for Devices {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::One(id) => write!(f, "{id}"),
            Self::List(list) => list.fmt(f),
            Self::All => f.write_str("all"),
        }
    }
}

/// A clap parser for [`Devices`] of `range`.
pub fn devices(range: IdRange) -> impl Fn(&str) -> Result<Devices, String> + Clone + Send + Sync + 'static {
    move |text| {
        let text = text.trim();
        if text.eq_ignore_ascii_case("all") {
            return Ok(Devices::All);
        }
        let list = parse_list(text, range, false)?;
        match list.0[..] {
            [one] if text.chars().all(|c| c.is_ascii_digit()) => Ok(Devices::One(one)),
            _ => Ok(Devices::List(list)),
        }
    }
}

/// A clap parser for the nodes of a read: one id or a list. `all` would
/// mean asking each of 127 node ids on the bus, which is a scan, not a read.
pub fn nodes(range: IdRange) -> impl Fn(&str) -> Result<Devices, String> + Clone + Send + Sync + 'static {
    let devices = devices(range);
    move |text| match devices(text)? {
        Devices::All => Err(format!("name the {} (e.g. 1 or 1,2); all is not supported", range.what)),
        d => Ok(d),
    }
}

/// A clap parser for a non-empty list of ids of `range`.
pub fn list(range: IdRange) -> impl Fn(&str) -> Result<IdList, String> + Clone + Send + Sync + 'static {
    move |text| parse_list(text, range, false)
}

/// A clap parser for a list of ids of `range` that may be empty.
pub fn list_or_none(range: IdRange) -> impl Fn(&str) -> Result<IdList, String> + Clone + Send + Sync + 'static {
    move |text| parse_list(text, range, true)
}

#[cfg(test)]
mod tests {
    use super::*;
    use axisctl::family::{CDIOS_MODULE, PAC_AXIS, POWERCUBE_MODULE};

    /// A default given as a value (`--node`'s factory node) reads back as
    /// itself.
    #[test]
    fn devices_are_shown_as_they_are_typed() {
        let parse = devices(POWERCUBE_MODULE);
        for text in ["17", "3,5,17", "1-8", "all"] {
            let d = parse(text).unwrap();
            assert_eq!((d.to_string(), parse(&d.to_string()).unwrap()), (text.to_string(), d));
        }
    }

    #[test]
    fn lists_take_ids_and_ranges_once_each() {
        assert_eq!(parse_list("17, 3,5,3", POWERCUBE_MODULE, false), Ok(IdList(vec![3, 5, 17])));
        assert_eq!(parse_list("1-4,2", PAC_AXIS, false), Ok(IdList(vec![1, 2, 3, 4])));
        assert_eq!(parse_list("0,15", CDIOS_MODULE, false), Ok(IdList(vec![0, 15])));
        assert_eq!(parse_list("", CDIOS_MODULE, true), Ok(IdList(vec![])));
    }

    #[test]
    fn lists_print_as_typed() {
        for (typed, shown) in [("1-31", "1-31"), ("17,3,5", "3,5,17"), ("1,2,4-6,9", "1,2,4-6,9"), ("", "")] {
            assert_eq!(parse_list(typed, POWERCUBE_MODULE, true).unwrap().to_string(), shown, "{typed}");
        }
    }

    #[test]
    fn bad_lists_say_why() {
        assert_eq!(parse_list("0", POWERCUBE_MODULE, false).unwrap_err(), "\"0\" is not a valid module id 1 to 31");
        assert_eq!(parse_list("17", PAC_AXIS, false).unwrap_err(), "\"17\" is not a valid axis 1 to 16");
        assert_eq!(parse_list("x", PAC_AXIS, false).unwrap_err(), "\"x\" is not a number");
        assert_eq!(parse_list("5-3", PAC_AXIS, false).unwrap_err(), "range \"5-3\" runs backwards");
        assert_eq!(parse_list(" , ", CDIOS_MODULE, false).unwrap_err(), "the list names no module id");
    }

    #[test]
    fn devices_keep_the_form_typed() {
        let p = devices(POWERCUBE_MODULE);
        assert_eq!(p("17"), Ok(Devices::One(17)));
        assert_eq!(p("17,"), Ok(Devices::List(IdList(vec![17]))));
        assert_eq!(p("5,3"), Ok(Devices::List(IdList(vec![3, 5]))));
        assert_eq!(p("ALL"), Ok(Devices::All));
        assert_eq!(p("0").unwrap_err(), "\"0\" is not a valid module id 1 to 31");
        assert!(p("alle").is_err());
    }

    #[test]
    fn single_ids_take_the_registry_range() {
        let p = id(POWERCUBE_MODULE);
        assert_eq!(p("31"), Ok(31));
        assert_eq!(p("32").unwrap_err(), "\"32\" is not a valid module id 1 to 31");
        assert!(p("0").is_err() && p("300").is_err() && p("x").is_err());
    }

    #[test]
    fn numbers_say_their_range_in_words() {
        let p = number(1u64, 60_000, "ms");
        assert_eq!(p("60000"), Ok(60_000));
        assert_eq!(p("0").unwrap_err(), "\"0\" is not a number from 1 to 60000 ms");
        assert!(p("abc").is_err());
    }
}
