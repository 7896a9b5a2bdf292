//! The outcome of a run: every check with its measured values beside their
//! limits, the report document (`axisctl-commission/1`, schema in
//! schema/commission-report.schema.json) and its Markdown and HTML forms.
//! The HTML is one self-contained file (styles and SVG plots inline), the
//! pass/fail summary first, so it opens and prints in any browser.

use serde::Serialize;

use super::plan::Plan;

pub const SCHEMA: &str = "axisctl-commission/1";

/// How a check ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Status {
    /// Every measured value within its limit.
    Pass,
    /// A value outside its limit, or the device refused or faulted.
    Fail,
    /// Not run: `--dry-run`, an interruption, or an earlier check failed
    /// so that this one could not run safely (the reason is in `detail`).
    Skipped,
}

impl Status {
    pub fn name(self) -> &'static str {
        match self {
            Self::Pass => "pass",
            Self::Fail => "fail",
            Self::Skipped => "skipped",
        }
    }
}

/// One measured value beside its limit.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Measure {
    pub name: String,
    /// The value read or computed (`null`: none, e.g. a response that never
    /// reached its band).
    pub value: serde_json::Value,
    /// What the plan asks, as text (`<= 0.5`, `12333`, `1.5 ± 0.01`).
    pub limit: String,
    #[serde(skip_serializing_if = "String::is_empty")]
    pub unit: String,
    pub pass: bool,
}

/// One check of one device.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Check {
    /// The bench address, `powercube:5`.
    pub device: String,
    /// `identity`, `settings`, `limits`, `home`, `move_forward`,
    /// `move_back`, `halt`, `watchdog`, `backup`.
    pub check: String,
    pub status: Status,
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub measured: Vec<Measure>,
    /// What happened, in a sentence (why it failed or was skipped).
    #[serde(skip_serializing_if = "String::is_empty")]
    pub detail: String,
    /// The recording of a move, relative to the report's directory.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub recording: Option<String>,
    /// The backup file, relative to the report's directory.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub file: Option<String>,
    /// Seconds from the run's start.
    pub t: f64,
    /// How long the check took, in seconds.
    pub duration_s: f64,
    /// The recording's plot (HTML only).
    #[serde(skip)]
    pub svg: Option<String>,
}

impl Check {
    pub fn new(device: &str, check: &str) -> Self {
        Self {
            device: device.into(),
            check: check.into(),
            status: Status::Pass,
            measured: Vec::new(),
            detail: String::new(),
            recording: None,
            file: None,
            t: 0.0,
            duration_s: 0.0,
            svg: None,
        }
    }

    /// Adds a measured value; a value out of its limit fails the check.
    pub fn measure(&mut self, name: &str, value: serde_json::Value, limit: String, unit: &str, pass: bool) {
        if !pass && self.status == Status::Pass {
            self.status = Status::Fail;
        }
        self.measured.push(Measure { name: name.into(), value, limit, unit: unit.into(), pass });
    }

    pub fn fail(mut self, detail: impl Into<String>) -> Self {
        self.status = Status::Fail;
        self.detail = detail.into();
        self
    }

    pub fn skipped(mut self, detail: impl Into<String>) -> Self {
        self.status = Status::Skipped;
        self.detail = detail.into();
        self
    }
}

/// Counts by status.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct Summary {
    pub passed: usize,
    pub failed: usize,
    pub skipped: usize,
}

/// The report document.
#[derive(Debug, Clone, Serialize)]
pub struct Report {
    pub schema: &'static str,
    /// `axisctl 0.1.0 (...)`.
    pub created_by: String,
    /// UTC, `2026-12-04T20:05:00Z`.
    pub started: String,
    pub duration_s: f64,
    /// The bench's links, as given.
    pub bench: String,
    /// False when the run was interrupted (Ctrl-C) or ended on an error:
    /// checks not reached are missing, not passed.
    pub complete: bool,
    /// `--dry-run`: nothing moved, the motions were listed only.
    pub dry_run: bool,
    /// Every check passed (and the run is complete).
    pub passed: bool,
    pub summary: Summary,
    /// Why the run ended early, when it did.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub ended: Option<String>,
    /// The motions the plan makes, as listed before confirmation.
    pub motions: Vec<String>,
    pub plan: Plan,
    pub checks: Vec<Check>,
}

impl Report {
    /// Counts and the verdict from the checks.
    pub fn settle(&mut self) {
        let count = |s| self.checks.iter().filter(|c| c.status == s).count();
        self.summary =
            Summary { passed: count(Status::Pass), failed: count(Status::Fail), skipped: count(Status::Skipped) };
        self.passed = self.complete && self.summary.failed == 0;
    }

    pub fn json(&self) -> String {
        serde_json::to_string_pretty(self).unwrap_or_default() + "\n"
    }

    fn verdict(&self) -> &'static str {
        match (self.complete, self.passed, self.dry_run) {
            (false, _, _) => "INCOMPLETE",
            (true, true, true) => "PASSED (dry run: nothing moved)",
            (true, true, false) => "PASSED",
            (true, false, _) => "FAILED",
        }
    }

    /// The report as Markdown: summary, bench, then one table per device.
    pub fn markdown(&self) -> String {
        let mut s = format!("# Commissioning report: {}\n\n", self.verdict());
        s += &format!(
            "{} passed, {} failed, {} skipped.\n\n",
            self.summary.passed, self.summary.failed, self.summary.skipped
        );
        if let Some(why) = &self.ended {
            s += &format!("**Ended early:** {why}\n\n");
        }
        s += &format!(
            "- Bench: `{}`\n- Started: {}\n- Duration: {:.1} s\n- Written by: {}\n\n",
            self.bench, self.started, self.duration_s, self.created_by
        );
        if !self.motions.is_empty() {
            s += "## Motions\n\n";
            self.motions.iter().for_each(|m| s += &format!("- {m}\n"));
            s += "\n";
        }
        for dev in self.devices() {
            s += &format!("## {dev}\n\n| check | status | measured | limit | |\n|---|---|---|---|---|\n");
            for c in self.checks.iter().filter(|c| c.device == dev) {
                s += &format!("| {} | **{}** | | | {} |\n", c.check, c.status.name(), md(&c.detail));
                for m in &c.measured {
                    let mark = if m.pass { "ok" } else { "**out**" };
                    s += &format!(
                        "| | {} | {} {} | {} | {mark} |\n",
                        md(&m.name),
                        value_text(&m.value),
                        m.unit,
                        md(&m.limit)
                    );
                }
                if let Some(r) = c.recording.as_ref().or(c.file.as_ref()) {
                    s += &format!("| | file | [{r}]({r}) | | |\n");
                }
            }
            s += "\n";
        }
        s += "## Plan\n\n```toml\n";
        s += &self.plan.to_toml();
        s += "```\n";
        s
    }

    /// The report as one HTML file: no external resource.
    pub fn html(&self) -> String {
        let verdict_class = if self.passed { "pass" } else { "fail" };
        let mut s = String::from(
            "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">\n<title>Commissioning report</title>\n<style>\n\
             body{font-family:sans-serif;margin:2em;color:#222}table{border-collapse:collapse;margin:0.5em 0 1.5em}\
             td,th{border:1px solid #bbb;padding:0.25em 0.6em;text-align:left;vertical-align:top}\
             .pass{color:#176d17;font-weight:bold}.fail{color:#b00;font-weight:bold}.skipped{color:#777}\
             .verdict{font-size:1.6em;padding:0.3em 0.6em;border:2px solid}\
             svg{max-width:100%;height:auto}pre{background:#f4f4f4;padding:0.8em}\
             @media print{.plot{page-break-inside:avoid}}\n</style></head><body>\n",
        );
        s += &format!(
            "<h1>Commissioning report</h1>\n<p class=\"verdict {verdict_class}\">{}</p>\n<p>{} passed, {} failed, {} skipped.</p>\n",
            esc(self.verdict()),
            self.summary.passed,
            self.summary.failed,
            self.summary.skipped
        );
        if let Some(why) = &self.ended {
            s += &format!("<p class=\"fail\">Ended early: {}</p>\n", esc(why));
        }
        s += "<h2>Summary</h2>\n<table><tr><th>device</th><th>check</th><th>status</th><th>detail</th></tr>\n";
        for c in &self.checks {
            s += &format!(
                "<tr><td>{}</td><td>{}</td><td class=\"{}\">{}</td><td>{}</td></tr>\n",
                esc(&c.device),
                esc(&c.check),
                c.status.name(),
                c.status.name(),
                esc(&c.detail)
            );
        }
        s += "</table>\n<h2>Bench</h2>\n<table>\n";
        for (k, v) in [
            ("bench", self.bench.clone()),
            ("started", self.started.clone()),
            ("duration", format!("{:.1} s", self.duration_s)),
            ("written by", self.created_by.clone()),
            ("complete", self.complete.to_string()),
            ("dry run", self.dry_run.to_string()),
        ] {
            s += &format!("<tr><th>{k}</th><td>{}</td></tr>\n", esc(&v));
        }
        s += "</table>\n";
        if !self.motions.is_empty() {
            s += "<h2>Motions</h2>\n<ul>\n";
            self.motions.iter().for_each(|m| s += &format!("<li>{}</li>\n", esc(m)));
            s += "</ul>\n";
        }
        for dev in self.devices() {
            s += &format!("<h2>{}</h2>\n", esc(&dev));
            s +=
                "<table><tr><th>check</th><th>status</th><th>measured</th><th>value</th><th>limit</th><th></th></tr>\n";
            for c in self.checks.iter().filter(|c| c.device == dev) {
                let rows = c.measured.len().max(1);
                s += &format!(
                    "<tr><td rowspan=\"{rows}\">{}</td><td rowspan=\"{rows}\" class=\"{}\">{}</td>",
                    esc(&c.check),
                    c.status.name(),
                    c.status.name()
                );
                if c.measured.is_empty() {
                    s += &format!("<td colspan=\"4\">{}</td></tr>\n", esc(&c.detail));
                }
                for (i, m) in c.measured.iter().enumerate() {
                    if i > 0 {
                        s += "<tr>";
                    }
                    let mark =
                        if m.pass { "<span class=\"pass\">ok</span>" } else { "<span class=\"fail\">out</span>" };
                    s += &format!(
                        "<td>{}</td><td>{} {}</td><td>{}</td><td>{mark}</td></tr>\n",
                        esc(&m.name),
                        esc(&value_text(&m.value)),
                        esc(&m.unit),
                        esc(&m.limit)
                    );
                }
            }
            s += "</table>\n";
            for c in self.checks.iter().filter(|c| c.device == dev && c.svg.is_some()) {
                s += &format!("<div class=\"plot\"><h3>{} {}</h3>\n", esc(&dev), esc(&c.check));
                s += c.svg.as_deref().unwrap_or_default();
                s += "</div>\n";
            }
        }
        s += "<h2>Plan</h2>\n<pre>";
        s += &esc(&self.plan.to_toml());
        s += "</pre>\n</body></html>\n";
        s
    }

    /// The devices in the order their first check came.
    fn devices(&self) -> Vec<String> {
        let mut out: Vec<String> = Vec::new();
        for c in &self.checks {
            if !out.contains(&c.device) {
                out.push(c.device.clone());
            }
        }
        out
    }
}

fn value_text(v: &serde_json::Value) -> String {
    match v {
        serde_json::Value::Null => "none".into(),
        serde_json::Value::String(s) => s.clone(),
        serde_json::Value::Number(n) => match n.as_f64() {
            Some(f) if n.is_f64() => format!("{}", (f * 1e6).round() / 1e6),
            _ => n.to_string(),
        },
        other => other.to_string(),
    }
}

/// Text safe in a Markdown table cell.
fn md(s: &str) -> String {
    s.replace('|', "\\|").replace('\n', " ")
}

/// Text safe in HTML.
fn esc(s: &str) -> String {
    s.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;").replace('"', "&quot;")
}

#[cfg(test)]
mod tests {
    use super::*;

    fn report(checks: Vec<Check>) -> Report {
        let mut r = Report {
            schema: SCHEMA,
            created_by: "axisctl test".into(),
            started: "2026-12-04T20:00:00Z".into(),
            duration_s: 1.0,
            bench: "sim".into(),
            complete: true,
            dry_run: false,
            passed: false,
            summary: Summary::default(),
            ended: None,
            motions: vec!["powercube:3: ramp to 0.5 rad and back".into()],
            plan: Plan { device: Vec::new() },
            checks,
        };
        r.settle();
        r
    }

    #[test]
    fn one_value_out_of_its_limit_fails_the_check_and_the_run() {
        let mut c = Check::new("powercube:5", "identity");
        c.measure("serial", 12333.into(), "12333".into(), "", true);
        assert_eq!(c.status, Status::Pass);
        c.measure("firmware", "4.6.01".into(), "4.6.02".into(), "", false);
        assert_eq!(c.status, Status::Fail);
        let r = report(vec![c, Check::new("powercube:3", "limits")]);
        assert_eq!(r.summary, Summary { passed: 1, failed: 1, skipped: 0 });
        assert!(!r.passed);
        assert!(r.markdown().starts_with("# Commissioning report: FAILED"));
        let mut incomplete = report(vec![Check::new("powercube:3", "limits")]);
        incomplete.complete = false;
        incomplete.settle();
        assert!(!incomplete.passed, "an interrupted run never passes");
    }

    #[test]
    fn html_is_self_contained_and_escaped() {
        let mut c = Check::new("powercube:5", "move_forward");
        c.detail = "<script>alert(1)</script> & more".into();
        c.svg = Some("<svg><polyline/></svg>".into());
        let html = report(vec![c]).html();
        assert!(html.contains("&lt;script&gt;alert(1)&lt;/script&gt; &amp; more"));
        assert!(!html.contains("<script"), "no script, escaped or inline");
        assert!(html.contains("<svg><polyline/></svg>"), "the plot inline");
        assert!(!html.contains("src=\"http") && !html.contains("href=\"http"), "no external resource");
        let summary = html.find("<h2>Summary</h2>").unwrap();
        assert!(summary < html.find("<h2>Bench</h2>").unwrap(), "the summary first");
    }
}
