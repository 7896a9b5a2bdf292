//! `p`: the selected device's chart as an SVG file, drawn by the same code
//! as `axisctl plot` ([`crate::plot`]). The App asks for it
//! ([`App::snapshot`](super::app::App::snapshot)); the dashboard's loop
//! calls [`write`] and reports back, so the App stays free of I/O.

use crate::address::Address;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::{SystemTime, UNIX_EPOCH};

use super::app::ChartRequest;
use crate::plot;

/// Size of the SVG, in pixels: room for three stacked panels.
pub const WIDTH: u32 = 960;
pub const HEIGHT: u32 = 720;

#[derive(Debug, thiserror::Error)]
pub enum SnapshotError {
    #[error(transparent)]
    Plot(#[from] plot::PlotError),
    #[error("cannot write {path}: {source}")]
    Io { path: String, source: std::io::Error },
}

/// The chart in `axisctl plot`'s terms: one series per quantity, each with
/// its unit (so each gets its own panel), time in seconds before the snapshot.
pub fn chart(req: &ChartRequest) -> plot::Chart {
    plot::Chart {
        title: req.title.clone(),
        x_label: "t (s, 0 = when the snapshot was taken)".into(),
        series: req
            .traces
            .iter()
            .map(|t| plot::Series { name: t.name.into(), unit: Some(t.unit.into()), points: t.points.clone() })
            .collect(),
    }
}

/// `powercube-17`, `pac-axis-2`, `cdios-1-0`: a device in a file name.
pub fn slug(device: Address) -> String {
    match device {
        Address::PowerCube { module: m } => format!("powercube-{m}"),
        Address::Pac { axis: None } => "pac".into(),
        Address::Pac { axis: Some(a) } => format!("pac-axis-{a}"),
        Address::Cdios { node, module } => format!("cdios-{node}-{module}"),
    }
}

/// `20261202T034512Z`: UTC, sortable, no characters a file system refuses.
pub fn utc_stamp(wall: SystemTime) -> String {
    let secs = wall.duration_since(UNIX_EPOCH).map_or(0, |d| d.as_secs());
    let (days, rest) = (secs / 86_400, secs % 86_400);
    // Days since 1970-01-01 to a civil date (H. Hinnant's algorithm).
    let z = days as i64 + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = doy - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = yoe + era * 400 + i64::from(month <= 2);
    format!("{year:04}{month:02}{day:02}T{:02}{:02}{:02}Z", rest / 3600, rest % 3600 / 60, rest % 60)
}

/// `axisctl-chart-powercube-17-20261202T034512Z.svg`.
pub fn file_name(device: Address, wall: SystemTime) -> String {
    format!("axisctl-chart-{}-{}.svg", slug(device), utc_stamp(wall))
}

/// Draws the chart and writes it into `dir`, never over an existing file
/// (two snapshots in one second get `-2`, `-3`, … ); returns the path.
pub fn write(dir: &Path, req: &ChartRequest, wall: SystemTime) -> Result<PathBuf, SnapshotError> {
    let svg = plot::svg(&chart(req), WIDTH, HEIGHT)?;
    let name = file_name(req.device, wall);
    let stem = name.trim_end_matches(".svg");
    let mut n = 1;
    loop {
        let path = if n == 1 { dir.join(&name) } else { dir.join(format!("{stem}-{n}.svg")) };
        let io = |source| SnapshotError::Io { path: path.display().to_string(), source };
        match std::fs::OpenOptions::new().write(true).create_new(true).open(&path) {
            Ok(mut f) => {
                f.write_all(svg.as_bytes()).and_then(|()| f.sync_all()).map_err(io)?;
                return Ok(path);
            }
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists && n < 100 => n += 1,
            Err(e) => return Err(io(e)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Duration;

    #[test]
    fn utc_stamps_are_civil_dates() {
        assert_eq!(utc_stamp(UNIX_EPOCH), "19700101T000000Z");
        // 2000-02-29 (a leap day of a century year) 12:34:56.
        assert_eq!(utc_stamp(UNIX_EPOCH + Duration::from_secs(951_827_696)), "20000229T123456Z");
        assert_eq!(utc_stamp(UNIX_EPOCH + Duration::from_secs(1_796_182_576)), "20261202T033616Z");
    }

    #[test]
    fn file_names_name_the_device() {
        let t = UNIX_EPOCH;
        assert_eq!(file_name(Address::PowerCube { module: 17 }, t), "axisctl-chart-powercube-17-19700101T000000Z.svg");
        assert_eq!(file_name(Address::Pac { axis: Some(2) }, t), "axisctl-chart-pac-axis-2-19700101T000000Z.svg");
        assert_eq!(file_name(Address::Cdios { node: 1, module: 0 }, t), "axisctl-chart-cdios-1-0-19700101T000000Z.svg");
    }
}
