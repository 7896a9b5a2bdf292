//! `record` and `plot`, as typed (clap derive only).

use std::path::PathBuf;
use std::time::Duration;

use clap::{Args, ValueEnum};

/// How samples are written.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Format {
    /// One JSON object per sample and line (the same as --json)
    Jsonl,
    /// A header line with each column's unit, then one line per sample
    Csv,
    /// Aligned columns for a person
    Text,
}

#[derive(Debug, Args)]
pub struct RecordArgs {
    /// PowerCube module ids (17 or 3,5,17); with --node, Cdios 6168 module ids (0..15)
    #[arg(short, long = "module", value_name = "ID[,ID...]")]
    pub module: Option<String>,
    /// PA-CONTROL axes to record (2 or 1,2)
    #[arg(long, value_name = "AXIS[,AXIS...]")]
    pub axis: Option<String>,
    /// Cdios node id (1..127): record the Cdios 6168 modules given with -m on it
    #[arg(long, value_name = "N")]
    pub node: Option<u8>,
    /// The devices to record, of any family on any link of the bench (instead of -m, --axis, --node): powercube:ID, pac:AXIS, cdios:NODE/MODULE or bench-file names; each VALUE of each device
    #[arg(short, long, value_name = "DEVICE[,DEVICE...]", value_delimiter = ',', num_args = 1,
          conflicts_with_all = ["module", "axis", "node"], add = super::complete::bench_devices(None))]
    pub device: Option<Vec<axisctl::bench::DeviceRef>>,
    /// The values: PowerCube parameter names (ActPos ActVel Cur; `axisctl params powercube`);
    /// PA-CONTROL position, speed, status; Cdios position, setpoint, speed, rpm-error.
    /// Or DEVICE.VALUE for devices anywhere on the bench (powercube:3.ActPos pac:2.position
    /// cdios:1/0.speed, or a bench file's name: shoulder.ActPos), each read on its family's link
    #[arg(value_name = "VALUE", required = true, add = super::complete::record_values())]
    pub values: Vec<String>,
    /// Samples per second (default: as fast as the link allows)
    #[arg(long, value_name = "HZ")]
    pub rate: Option<f64>,
    /// Stop after this long: 5s, 500ms, 2m or seconds (default: until --count or Ctrl-C)
    #[arg(long = "for", value_name = "TIME", value_parser = duration)]
    pub duration: Option<Duration>,
    /// Stop after this many samples
    #[arg(long, value_name = "N")]
    pub count: Option<u64>,
    /// Output format (default: jsonl with --json, else text)
    #[arg(long, value_enum)]
    pub format: Option<Format>,
    /// A motion command started on the same link once recording runs, e.g. `-- move-ramp -m 17 0.1`;
    /// it is halted if the recording ends (or fails, or is interrupted) while it still moves
    #[arg(last = true, value_name = "MOTION")]
    pub motion: Vec<String>,
}

#[derive(Debug, Args)]
#[command(group(clap::ArgGroup::new("output").args(["svg", "png"]).required(true).multiple(true)))]
pub struct PlotArgs {
    /// A recording of `axisctl record` (JSON Lines or CSV; - for stdin)
    #[arg(value_name = "REC")]
    pub recording: PathBuf,
    /// Write the chart as SVG here (- for standard output)
    #[arg(long, value_name = "FILE")]
    pub svg: Option<PathBuf>,
    /// Write the chart as PNG here (at most 32 million pixels; - for standard output)
    #[arg(long, value_name = "FILE")]
    pub png: Option<PathBuf>,
    /// Chart title (default: the recording's file name)
    #[arg(long)]
    pub title: Option<String>,
    /// Width in pixels
    #[arg(long, default_value_t = 1000, value_parser = clap::value_parser!(u32).range(120..=20000))]
    pub width: u32,
    /// Height in pixels (default: 300 per unit)
    #[arg(long, value_parser = clap::value_parser!(u32).range(110..=20000))]
    pub height: Option<u32>,
}

/// `5s`, `500ms`, `2m`, `1.5` (seconds).
pub fn duration(text: &str) -> Result<Duration, String> {
    let t = text.trim();
    let (num, scale) = if let Some(n) = t.strip_suffix("ms") {
        (n, 1e-3)
    } else if let Some(n) = t.strip_suffix('s') {
        (n, 1.0)
    } else if let Some(n) = t.strip_suffix("min").or_else(|| t.strip_suffix('m')) {
        (n, 60.0)
    } else {
        (t, 1.0)
    };
    let v: f64 = num.trim().parse().map_err(|_| format!("{text:?} is no duration: try 5s, 500ms or 2m"))?;
    let secs = v * scale;
    if !secs.is_finite() || secs <= 0.0 || secs > 7.0 * 86400.0 {
        return Err(format!("{text} is out of range: more than 0 and at most 7 days"));
    }
    Ok(Duration::from_secs_f64(secs))
}

#[cfg(test)]
mod tests {
    use super::duration;
    use std::time::Duration;

    #[test]
    fn durations_take_their_unit() {
        assert_eq!(duration("5s"), Ok(Duration::from_secs(5)));
        assert_eq!(duration("500ms"), Ok(Duration::from_millis(500)));
        assert_eq!(duration("2m"), Ok(Duration::from_secs(120)));
        assert_eq!(duration("0.25"), Ok(Duration::from_millis(250)));
        assert!(duration("0s").is_err() && duration("-1").is_err() && duration("abc").is_err());
    }
}
