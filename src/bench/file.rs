//! The bench file (TOML): one `[[link]]` table per link, with its `spec`,
//! optionally the `families` on it and the `devices` expected, by name.
//! Every error names the file and the line; an unknown key is an error, so
//! a misspelt `familes` never leaves a link with the wrong families.

use std::collections::BTreeMap;
use std::ops::Range;
use std::path::{Path, PathBuf};

use serde::Deserialize;
use toml::Spanned;

use super::{default_families, fits, port, BenchLink};
use crate::address::{self, Address};
use crate::family::Family;
use crate::link::LinkSpec;

/// What is wrong with a bench file, with where.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum FileError {
    #[error("bench file {}: {error}", path.display())]
    Read { path: PathBuf, error: String },
    #[error("bench file {}, line {line}: {message}", path.display())]
    At { path: PathBuf, line: usize, message: String },
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Doc {
    #[serde(default)]
    link: Vec<Spanned<Link>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Link {
    spec: Spanned<String>,
    families: Option<Spanned<Vec<Spanned<String>>>>,
    #[serde(default)]
    devices: BTreeMap<Spanned<String>, Spanned<String>>,
}

/// The most a bench file may hold: one names a few links and their
/// devices, a few KiB; an endless file (`/dev/zero`) stops here.
pub const MAX_BYTES: u64 = 1 << 20;

pub(super) fn read(path: &Path) -> Result<Vec<BenchLink>, FileError> {
    use std::io::Read;
    let failed = |error: String| FileError::Read { path: path.to_path_buf(), error };
    let file = std::fs::File::open(path).map_err(|e| failed(e.to_string()))?;
    let mut bytes = Vec::new();
    file.take(MAX_BYTES + 1).read_to_end(&mut bytes).map_err(|e| failed(e.to_string()))?;
    if bytes.len() as u64 > MAX_BYTES {
        return Err(failed(format!("larger than {} MiB, the most a bench file may be", MAX_BYTES >> 20)));
    }
    let text = String::from_utf8(bytes).map_err(|_| failed("not UTF-8 text".into()))?;
    parse(&text, path)
}

pub(super) fn parse(text: &str, path: &Path) -> Result<Vec<BenchLink>, FileError> {
    let at = |span: Range<usize>, message: String| FileError::At {
        path: path.to_path_buf(),
        line: 1 + text[..span.start.min(text.len())].matches('\n').count(),
        message,
    };
    let doc: Doc = toml::from_str(text).map_err(|e| at(e.span().unwrap_or(0..0), e.message().trim().to_string()))?;
    if doc.link.is_empty() {
        return Err(at(0..0, "no [[link]] table: a bench file names at least one link".into()));
    }
    let mut links: Vec<BenchLink> = Vec::new();
    for link in doc.link {
        let link = link.into_inner();
        let text_spec = link.spec.get_ref().trim();
        let spec: LinkSpec = text_spec.parse().map_err(|e| at(link.spec.span(), format!("spec: {e}")))?;
        if links.iter().any(|l| port(&l.spec) == port(&spec)) {
            return Err(at(link.spec.span(), format!("{text_spec} is named twice (each port is opened once)")));
        }
        let families = match &link.families {
            None => default_families(&spec),
            Some(list) => {
                let mut fams = Vec::new();
                for f in list.get_ref() {
                    let family: Family = f.get_ref().parse().map_err(|e| at(f.span(), format!("families: {e}")))?;
                    if !fits(&spec, family) {
                        let over = if spec.is_can() { "CAN" } else { "a serial line" };
                        return Err(at(f.span(), format!("families: the {family} is not reached over {over}")));
                    }
                    if fams.contains(&family) {
                        return Err(at(f.span(), format!("families: {} is named twice", family.name())));
                    }
                    fams.push(family);
                }
                if fams.is_empty() {
                    return Err(at(list.span(), "families: empty (leave the key out for the link's defaults)".into()));
                }
                fams.sort();
                fams
            }
        };
        let mut devices = BTreeMap::new();
        for (name, addr) in &link.devices {
            let n = name.get_ref();
            if !address::is_name(n) {
                return Err(at(
                    name.span(),
                    format!(
                        "devices: {n:?} cannot be a name (a letter, then letters, digits, '_' and '-'; not a family)"
                    ),
                ));
            }
            let a: Address = addr.get_ref().parse().map_err(|e| at(addr.span(), format!("devices: {n}: {e}")))?;
            if !families.contains(&a.family()) {
                return Err(at(addr.span(), format!("devices: {n}: {a} is not of a family on {text_spec}")));
            }
            let taken = links.iter().flat_map(|l| &l.devices).chain(&devices).find(|(o, oa)| *o == n || **oa == a);
            if let Some((other, _)) = taken {
                return Err(at(name.span(), format!("devices: {n} = {a}: taken by {other}")));
            }
            devices.insert(n.clone(), a);
        }
        links.push(BenchLink { spec, text: text_spec.to_string(), families, devices });
    }
    Ok(links)
}

#[cfg(test)]
mod tests {
    use super::*;

    const EXAMPLE: &str = r#"
[[link]]
spec = "slcan:/dev/ttyACM0"
families = ["powercube", "cdios"]
devices = { shoulder = "powercube:3", elbow = "powercube:5", gripper = "cdios:1/0" }
[[link]]
spec = "serial:/dev/ttyUSB0"
families = ["pac"]
"#;

    fn parsed(text: &str) -> Result<Vec<BenchLink>, String> {
        parse(text, Path::new("axisctl.toml")).map_err(|e| e.to_string())
    }

    #[test]
    fn the_example_reads() {
        let links = parsed(EXAMPLE).unwrap();
        assert_eq!(links.len(), 2);
        assert_eq!(links[0].families, vec![Family::PowerCube, Family::Cdios]);
        assert_eq!(links[0].devices["gripper"], Address::Cdios { node: 1, module: 0 });
        assert_eq!(links[0].devices["shoulder"], Address::PowerCube { module: 3 });
        assert_eq!(links[1].families, vec![Family::Pac]);
        assert_eq!(links[1].text, "serial:/dev/ttyUSB0");
    }

    #[test]
    fn families_default_to_the_link_kind() {
        let links = parsed("[[link]]\nspec = \"serial:/dev/x\"\n[[link]]\nspec = \"sim\"\n").unwrap();
        assert_eq!(links[0].families, vec![Family::Pac]);
        assert_eq!(links[1].families, Family::ALL.to_vec());
        let rs232 = parsed("[[link]]\nspec = \"serial:/dev/x\"\nfamilies = [\"powercube\"]\n").unwrap();
        assert_eq!(rs232[0].families, vec![Family::PowerCube]);
    }

    #[test]
    fn errors_name_the_file_the_line_and_the_key() {
        let e = parsed("[[link]]\nspec = \"sim\"\nfamiles = [\"pac\"]\n").unwrap_err();
        assert!(e.starts_with("bench file axisctl.toml, line 3: unknown field `familes`"), "{e}");
        let e = parsed("[[link]]\nspec = \"sim\"\n[options]\n").unwrap_err();
        assert!(e.starts_with("bench file axisctl.toml, line 3: unknown field `options`"), "{e}");
        let cases = [
            ("[[link]]\nspec = \"can0\"\n", "line 2: spec: bad link"),
            (
                "[[link]]\nspec = \"slcan:/dev/a\"\nfamilies = [\"pac\"]\n",
                "line 3: families: the PA-CONTROL is not reached over CAN",
            ),
            (
                "[[link]]\nspec = \"serial:/dev/a\"\nfamilies = [\"cdios\"]\n",
                "line 3: families: the Cdios is not reached over a serial line",
            ),
            ("[[link]]\nspec = \"sim\"\nfamilies = [\"robot\"]\n", "line 3: families: unknown family \"robot\""),
            ("[[link]]\nspec = \"sim\"\nfamilies = []\n", "line 3: families: empty"),
            ("[[link]]\nspec = \"sim\"\n[[link]]\nspec = \"sim\"\n", "line 4: sim is named twice"),
            (
                "[[link]]\nspec = \"slcan:/dev/a\"\n[[link]]\nspec = \"serial:/dev/a\"\n",
                "line 4: serial:/dev/a is named twice",
            ),
            (
                "[[link]]\nspec = \"serial:/dev/a\"\ndevices = { arm = \"powercube:3\" }\n",
                "line 3: devices: arm: powercube:3 is not of a family on serial:/dev/a",
            ),
            (
                "[[link]]\nspec = \"sim\"\ndevices = { arm = \"powercube:0\" }\n",
                "line 3: devices: arm: device address \"powercube:0\": module id 1 to 31",
            ),
            ("[[link]]\nspec = \"sim\"\ndevices = { pac = \"pac:1\" }\n", "line 3: devices: \"pac\" cannot be a name"),
            (
                "[[link]]\nspec = \"sim\"\ndevices = { a = \"pac:1\", b = \"pac:1\" }\n",
                "line 3: devices: b = pac:1: taken by a",
            ),
            ("", "line 1: no [[link]] table"),
            ("[[link]]\nspec = 3\n", "line 2: invalid type"),
        ];
        for (text, want) in cases {
            let e = parsed(text).unwrap_err();
            assert!(e.starts_with(&format!("bench file axisctl.toml, {want}")), "{text:?}: {e}");
        }
    }
}
