//! `monitor --table`: one row per CAN id, as python-can's viewer and
//! cansniffer show a bus: how often each id was seen, how fast it repeats,
//! and its last frame decoded. Sans-IO: frames and their time stamps in,
//! rows out.

use std::collections::BTreeMap;

use super::FrameInfo;
use crate::proto::can_error::CanEvent;

/// What is known about one id.
#[derive(Debug, Clone, PartialEq)]
pub struct Row {
    /// The id in candump notation (`0A3`, `12345678`, `20000004` for an error frame).
    pub id: String,
    pub count: u64,
    /// Seconds between its last two frames (`None` after one frame).
    pub period: Option<f64>,
    /// Frames per second from its first to its last frame (`None` after one frame).
    pub rate: Option<f64>,
    /// The last frame's data, hex, spaced.
    pub data: String,
    /// The last frame decoded.
    pub summary: String,
    first: f64,
    last: f64,
}

/// The rows, in id order: standard ids, extended ids, then error frames.
#[derive(Debug, Default)]
pub struct Table {
    rows: BTreeMap<(u8, u32), Row>,
}

impl Table {
    pub fn add(&mut self, ts: f64, event: &CanEvent, info: &FrameInfo) {
        let (key, id, data) = match event {
            CanEvent::Frame(f) if f.is_extended() => ((1, f.id()), format!("{:08X}", f.id()), f.data().to_vec()),
            CanEvent::Frame(f) => ((0, f.id()), format!("{:03X}", f.id()), f.data().to_vec()),
            CanEvent::Error(e) => ((2, e.id()), format!("{:08X}", e.id()), e.data.to_vec()),
        };
        let data = data.iter().map(|b| format!("{b:02X}")).collect::<Vec<_>>().join(" ");
        let summary = match &info.error {
            Some(e) => format!("{} ({e})", info.summary),
            None => info.summary.clone(),
        };
        let row = self.rows.entry(key).or_insert_with(|| Row {
            id,
            count: 0,
            period: None,
            rate: None,
            data: String::new(),
            summary: String::new(),
            first: ts,
            last: ts,
        });
        if row.count > 0 {
            row.period = Some(ts - row.last);
            let span = ts - row.first;
            row.rate = (span > 0.0).then(|| row.count as f64 / span);
        }
        row.count += 1;
        row.last = ts;
        row.data = data;
        row.summary = summary;
    }

    pub fn rows(&self) -> impl Iterator<Item = &Row> {
        self.rows.values()
    }

    /// The table as text lines, a header first.
    pub fn lines(&self) -> Vec<String> {
        let mut out = vec![format!(
            "{:<8} {:>8} {:>11} {:>9}  {:<23}  {}",
            "ID", "COUNT", "PERIOD ms", "RATE /s", "DATA", "LAST"
        )];
        for r in self.rows() {
            let period = r.period.map_or("-".into(), |p| format!("{:.1}", p * 1e3));
            let rate = r.rate.map_or("-".into(), |p| format!("{p:.1}"));
            out.push(format!("{:<8} {:>8} {period:>11} {rate:>9}  {:<23}  {}", r.id, r.count, r.data, r.summary));
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::monitor::describe_event;
    use crate::proto::can_error::ErrorFrame;

    fn add(t: &mut Table, ts: f64, frame: &str) {
        let e = match ErrorFrame::parse_candump(frame) {
            Some(e) => CanEvent::Error(e.unwrap()),
            None => CanEvent::Frame(frame.parse().unwrap()),
        };
        t.add(ts, &e, &describe_event(&e));
    }

    #[test]
    fn one_row_per_id_with_count_period_rate_and_the_last_frame() {
        let mut t = Table::default();
        add(&mut t, 10.0, "0F1#01");
        add(&mut t, 10.5, "100#02");
        add(&mut t, 10.010, "0A3#0A3C0000803F");
        add(&mut t, 10.020, "0F1#01");
        add(&mut t, 10.050, "0F1#02");
        add(&mut t, 10.060, "20000040#0000000000000000");
        add(&mut t, 10.070, "12345678#DEAD");
        let rows: Vec<&Row> = t.rows().collect();
        let ids: Vec<&str> = rows.iter().map(|r| r.id.as_str()).collect();
        assert_eq!(ids, ["0A3", "0F1", "100", "12345678", "20000040"], "standard, extended, then errors");
        let f1 = rows[1];
        assert_eq!((f1.count, f1.data.as_str()), (3, "02"));
        assert!((f1.period.unwrap() - 0.030).abs() < 1e-9, "{:?}", f1.period);
        assert!((f1.rate.unwrap() - 40.0).abs() < 1e-6, "2 periods in 50 ms: {:?}", f1.rate);
        assert_eq!((rows[0].period, rows[0].rate), (None, None));
        assert_eq!(rows[0].summary, "ActPos = 1");
        assert_eq!(rows[4].summary, "bus error: bus off");
        let lines = t.lines();
        assert!(lines[0].starts_with("ID") && lines.len() == 6, "{lines:#?}");
        assert!(
            lines[2].starts_with("0F1") && lines[2].contains(" 30.0 ") && lines[2].contains("40.0"),
            "{}",
            lines[2]
        );
    }
}
