//! `plot`: a recording of `record` (JSON Lines or CSV) drawn as an SVG
//! and/or PNG chart by `axisctl::plot`, one line per recorded value, one
//! panel per unit.

use axisctl::plot::{self, Chart, Series};
use serde_json::{json, Value};

use super::{usage, Ctx};
use crate::cli::record::PlotArgs;
use crate::output::{self, say};

pub fn run(ctx: &Ctx, args: &PlotArgs) -> anyhow::Result<()> {
    let name = args.recording.display().to_string();
    let text = super::input::read_text(&args.recording, super::input::RECORDING, "a recording")?;
    let series = parse(&text).map_err(|e| usage(format!("{name}: {e}")))?;
    let title = args
        .title
        .clone()
        .unwrap_or_else(|| args.recording.file_name().map_or("recording".into(), |f| f.to_string_lossy().into_owned()));
    let chart = Chart { title, x_label: "t (s)".into(), series };
    let panels = plot::panels(&chart).len().max(1) as u32;
    let height = args.height.unwrap_or(60 + 300 * panels);
    // Both drawn before either is written: a size the chart cannot take
    // is a usage error with no file touched.
    let svg = args.svg.as_ref().map(|p| plot::svg(&chart, args.width, height).map(|t| (p, t.into_bytes())));
    let png = args.png.as_ref().map(|p| plot::png(&chart, args.width, height).map(|b| (p, b)));
    let to_stdout = [&args.svg, &args.png].into_iter().flatten().filter(|p| p.as_os_str() == "-").count();
    if to_stdout > 1 {
        return Err(usage("only one of --svg and --png can be - (standard output)"));
    }
    if to_stdout == 1 && ctx.json {
        return Err(usage(
            "--json prints its document on standard output, where a chart to - goes: write the chart to a file",
        ));
    }
    let files = [svg, png].into_iter().flatten().collect::<Result<Vec<_>, _>>().map_err(|e| usage(e.to_string()))?;
    for (path, bytes) in &files {
        if path.as_os_str() == "-" {
            use std::io::Write;
            let mut out = std::io::stdout().lock();
            out.write_all(bytes)
                .and_then(|()| out.flush())
                .map_err(|e| anyhow::anyhow!("cannot write the chart to standard output: {e}"))?;
            continue;
        }
        std::fs::write(path, bytes).map_err(|e| anyhow::anyhow!("cannot write {}: {e}", path.display()))?;
    }
    if to_stdout == 1 {
        // The chart is the output: a summary after it would be part of it.
        return Ok(());
    }
    let samples = chart.series.iter().map(|s| s.points.len()).max().unwrap_or(0);
    let written: Vec<String> = files.iter().map(|(p, _)| p.display().to_string()).collect();
    if ctx.json {
        let series: Vec<Value> = chart
            .series
            .iter()
            .map(|s| json!({"name": s.name, "unit": s.unit.clone().unwrap_or_default(), "samples": s.points.len()}))
            .collect();
        let mut doc = json!({"command": "plot", "series": series});
        for (key, path) in [("svg", &args.svg), ("png", &args.png)] {
            if let Some(p) = path {
                doc[key] = p.display().to_string().into();
            }
        }
        output::json(&doc);
    } else {
        say!("{}: {} series, {samples} samples, written to {}", name, chart.series.len(), written.join(" and "));
    }
    Ok(())
}

/// The series of a recording, JSON Lines or CSV (told apart by the first
/// character).
pub fn parse(text: &str) -> Result<Vec<Series>, String> {
    match text.trim_start().chars().next() {
        None => Err("the recording is empty".into()),
        Some('{') => parse_jsonl(text),
        Some(_) => parse_csv(text),
    }
}

fn find_or_add(series: &mut Vec<Series>, name: String, unit: Option<String>) -> usize {
    match series.iter().position(|s| s.name == name && s.unit == unit) {
        Some(i) => i,
        None => {
            series.push(Series { name, unit, points: Vec::new() });
            series.len() - 1
        }
    }
}

fn parse_jsonl(text: &str) -> Result<Vec<Series>, String> {
    let mut series = Vec::new();
    for (n, line) in text.lines().enumerate().filter(|(_, l)| !l.trim().is_empty()) {
        let v: Value = serde_json::from_str(line).map_err(|e| format!("line {}: not JSON ({e})", n + 1))?;
        let t = v["t"].as_f64().ok_or_else(|| format!("line {}: no time stamp \"t\"", n + 1))?;
        let devices = v["devices"].as_array().ok_or_else(|| format!("line {}: no \"devices\"", n + 1))?;
        for d in devices {
            let who = device_label(d);
            let values = d["values"].as_object().ok_or_else(|| format!("line {}: a device without values", n + 1))?;
            for (name, val) in values {
                let unit = val["unit"].as_str().filter(|u| !u.is_empty()).map(str::to_string);
                let i = find_or_add(&mut series, format!("{who} {name}"), unit);
                series[i].points.push((t, val["value"].as_f64().unwrap_or(f64::NAN)));
            }
        }
    }
    Ok(series)
}

/// `module 17`, `axis 2`, `node 1 module 0`, as in the CSV header.
fn device_label(d: &Value) -> String {
    match (d["family"].as_str(), d["module"].as_u64(), d["axis"].as_u64(), d["node"].as_u64()) {
        (Some("cdios"), Some(m), _, Some(n)) => format!("node {n} module {m}"),
        (_, _, Some(a), _) => format!("axis {a}"),
        (_, Some(m), _, _) => format!("module {m}"),
        _ => "device".into(),
    }
}

/// `name [unit]` -> (name, unit).
fn split_unit(col: &str) -> (String, Option<String>) {
    let col = col.trim();
    match col.strip_suffix(']').and_then(|c| c.rsplit_once(" [")) {
        Some((name, unit)) => (name.to_string(), Some(unit.to_string())),
        None => (col.to_string(), None),
    }
}

fn parse_csv(text: &str) -> Result<Vec<Series>, String> {
    let mut lines = text.lines().filter(|l| !l.trim().is_empty());
    let header = lines.next().ok_or("the recording is empty")?;
    let cols: Vec<&str> = header.split(',').collect();
    if cols.len() < 2 || !cols[0].trim().starts_with('t') {
        return Err("a CSV recording starts with a header: t [s],<value> [<unit>],...".into());
    }
    let mut series: Vec<Series> = cols[1..]
        .iter()
        .map(|c| {
            let (name, unit) = split_unit(c);
            Series { name, unit, points: Vec::new() }
        })
        .collect();
    for (n, line) in lines.enumerate() {
        let cells: Vec<&str> = line.split(',').collect();
        let t: f64 =
            cells[0].trim().parse().map_err(|_| format!("line {}: time {:?} is no number", n + 2, cells[0]))?;
        for (s, cell) in series.iter_mut().zip(cells.iter().skip(1)) {
            s.points.push((t, cell.trim().parse().unwrap_or(f64::NAN)));
        }
    }
    Ok(series)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn csv_and_jsonl_give_the_same_series() {
        let csv = "t [s],module 17 ActPos [m],module 17 ActVel [m/s]\n0,0,0\n0.5,0.05,0.1\n";
        let jsonl = concat!(
            r#"{"command":"record","t":0,"seq":0,"devices":[{"family":"powercube","link":"sim","module":17,"values":{"ActPos":{"value":0,"unit":"m"},"ActVel":{"value":0,"unit":"m/s"}}}]}"#,
            "\n",
            r#"{"command":"record","t":0.5,"seq":1,"devices":[{"family":"powercube","link":"sim","module":17,"values":{"ActPos":{"value":0.05,"unit":"m"},"ActVel":{"value":0.1,"unit":"m/s"}}}]}"#,
        );
        let (a, b) = (parse(csv).unwrap(), parse(jsonl).unwrap());
        assert_eq!(a, b);
        assert_eq!(a[1].name, "module 17 ActVel");
        assert_eq!(a[1].unit.as_deref(), Some("m/s"));
        assert_eq!(a[0].points, [(0.0, 0.0), (0.5, 0.05)]);
        assert!(parse("").is_err() && parse("{oops").is_err() && parse("x\n1").is_err());
    }
}
