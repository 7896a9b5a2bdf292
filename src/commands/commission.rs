//! `commission`: runs the plan (given, or the default one for the devices
//! found) over the bench, then writes the report, the recordings and the
//! final backup into `--out`. Nothing moves before the motions are listed
//! and confirmed (`--yes` for scripts; `--dry-run` moves nothing); from the
//! first motion on, the supervisor is armed, so Ctrl-C halts what moves and
//! the report of what was done is still written, marked incomplete.

use std::io::{BufRead, IsTerminal};
use std::path::{Path, PathBuf};
use std::time::SystemTime;

use axisctl::backup::{self, Document};
use axisctl::bench::{Address, DeviceRef};
use axisctl::commission::plan::{Band, DevicePlan, Home, Identity, Moves, Plan, Settings};
use axisctl::commission::report::{self, Check, Report};
use axisctl::commission::{powercube as cube_plan, Run, BACKUP_FILE};
use axisctl::device::powercube::Cubes;
use axisctl::device::supervisor;
use axisctl::family::Family;
use axisctl::proto::powercube::ModuleId;
use serde_json::json;

mod out_dir;

use super::{usage, Ctx, DeviceFault, Interrupted};
use crate::cli::commission::CommissionArgs;
use crate::output::{self, say};

pub fn run(ctx: &Ctx, args: CommissionArgs) -> anyhow::Result<()> {
    if args.print_plan {
        let plan = default_plan(ctx)?;
        if ctx.json {
            output::json(&json!({"command": "commission", "plan": plan}));
        } else {
            output::text(format_args!("{}", plan.to_toml()));
        }
        return Ok(());
    }
    let out = args.out.clone().ok_or_else(|| usage("--out DIR is needed: where the report is written"))?;
    let earlier = out_dir::inspect(&out).map_err(usage)?;
    let (plan, plan_dir) = match &args.plan {
        Some(p) => (read_plan(p)?, p.parent().map(Path::to_path_buf).unwrap_or_default()),
        None => (default_plan(ctx)?, PathBuf::new()),
    };
    // Every address and file of the plan is checked before anything is sent.
    let devices = resolve(ctx, &plan)?;
    let files = expected_files(&plan, &plan_dir)?;
    std::fs::create_dir_all(&out).map_err(|e| usage(format!("--out {}: {e}", out.display())))?;
    let motions: Vec<String> = devices
        .iter()
        .flat_map(|(_, d)| cube_plan::motions(&d.address, d, cube_plan::unit_of(d.identity.kind.as_deref())))
        .collect();
    if args.dry_run {
        list("The plan would make these motions (not made: --dry-run):", &motions);
    } else if !motions.is_empty() {
        confirm(&motions, args.yes)?;
        super::arm_interrupt()?;
    }
    let devices: Vec<(ModuleId, DevicePlan)> = devices.into_iter().map(|(m, d)| (m, d.clone())).collect();
    let (report, written) = execute(ctx, &args, plan, &devices, &files, motions)?;
    out_dir::clear(&earlier).map_err(anyhow::Error::msg)?;
    if !earlier.foreign.is_empty() && !ctx.json {
        let kept = earlier.foreign.join(", ");
        output::err_line(format_args!("note: {} also holds {kept}: not the run's, left as they are", out.display()));
    }
    write_report(&out, &report, written)?;
    if ctx.json {
        output::json(&json!({
            "command": "commission",
            "out": out.display().to_string(),
            "complete": report.complete,
            "passed": report.passed,
            "summary": report.summary,
        }));
    } else {
        print_summary(ctx, &report, &out);
    }
    if !report.complete {
        return Err(Interrupted(format!(": the report in {} is marked incomplete", out.display())).into());
    }
    if !report.passed {
        let failed: Vec<String> = report
            .checks
            .iter()
            .filter(|c| c.status == report::Status::Fail)
            .map(|c| format!("{} {}", c.device, c.check))
            .collect();
        return Err(DeviceFault(format!("commissioning failed: {}", failed.join(", "))).into());
    }
    Ok(())
}

fn read_plan(path: &Path) -> anyhow::Result<Plan> {
    // `-` reads standard input, and a plan is bounded like every file read.
    let text = super::input::read_text(path, super::input::PLAN, "a plan")?;
    Plan::parse(&text, &path.display().to_string()).map_err(|e| usage(e.to_string()))
}

/// Each planned device's address on the bench; only PowerCube modules are
/// commissioned yet, so any other family is refused before anything is sent.
fn resolve<'p>(ctx: &Ctx, plan: &'p Plan) -> anyhow::Result<Vec<(ModuleId, &'p DevicePlan)>> {
    let bench = ctx.bench()?;
    let mut out = Vec::new();
    for d in &plan.device {
        let r: DeviceRef = d.address.parse().map_err(|e| usage(format!("plan: {e}")))?;
        match bench.resolve(&r).map_err(|e| usage(format!("plan: {e}")))? {
            Address::PowerCube { module } => {
                out.push((ModuleId::new(module).ok_or_else(|| usage("module id out of range"))?, d));
            }
            other => {
                return Err(usage(format!(
                    "plan: {} is a {} device: commission runs PowerCube modules only so far",
                    d.address,
                    other.family().display_name()
                )))
            }
        }
        if let Some(s) = &d.settings {
            if let Some(name) = s.values.keys().find(|n| !cube_plan::known_setting(n)) {
                return Err(usage(format!("plan: {}: no PowerCube parameter {name:?}", d.address)));
            }
        }
    }
    Ok(out)
}

/// The backup files the plan's settings name, read once; relative paths
/// are the plan file's.
fn expected_files(plan: &Plan, dir: &Path) -> anyhow::Result<Vec<(PathBuf, Document)>> {
    let mut out: Vec<(PathBuf, Document)> = Vec::new();
    for p in plan.device.iter().filter_map(|d| d.settings.as_ref()?.backup.as_ref()) {
        let path = if p.is_absolute() { p.clone() } else { dir.join(p) };
        if out.iter().any(|(q, _)| *q == path) {
            continue;
        }
        let text = super::input::read_text(&path, super::input::BACKUP, "a backup")
            .map_err(|e| usage(format!("plan: {e:#}")))?;
        let doc = backup::parse(&path.display().to_string(), &text)?;
        out.push((path, doc));
    }
    Ok(out)
}

fn expected_for<'f>(d: &DevicePlan, m: ModuleId, dir_files: &'f [(PathBuf, Document)]) -> Option<&'f backup::Device> {
    let name = d.settings.as_ref()?.backup.as_ref()?;
    let (_, doc) = dir_files.iter().find(|(p, _)| p.ends_with(name))?;
    doc.devices.iter().find(|dev| dev.family == Family::PowerCube && dev.module == Some(m.get()))
}

fn list(title: &str, motions: &[String]) {
    output::err_line(format_args!("{title}"));
    for m in motions {
        output::err_line(format_args!("  {m}"));
    }
}

/// Lists the motions on stderr and asks; `--yes` answers for a script. A
/// standard input that is no terminal cannot answer: refused, nothing sent.
fn confirm(motions: &[String], yes: bool) -> anyhow::Result<()> {
    list("The plan makes these motions:", motions);
    if yes {
        return Ok(());
    }
    if !std::io::stdin().is_terminal() {
        return Err(usage(
            "the motions need a confirmation and standard input is not a terminal: give --yes, or --dry-run to move \
             nothing; nothing was sent",
        ));
    }
    output::err_text(format_args!("Make these motions? [y/N] "));
    let mut answer = String::new();
    std::io::stdin().lock().read_line(&mut answer)?;
    if matches!(answer.trim(), "y" | "Y" | "yes") {
        Ok(())
    } else {
        Err(anyhow::anyhow!("not confirmed: nothing was moved (--dry-run runs the checks that do not move)"))
    }
}

fn execute(
    ctx: &Ctx,
    args: &CommissionArgs,
    plan: Plan,
    devices: &[(ModuleId, DevicePlan)],
    files: &[(PathBuf, Document)],
    motions: Vec<String>,
) -> anyhow::Result<(Report, Files)> {
    let started = SystemTime::now();
    let total = devices.iter().map(|(_, d)| cube_plan::planned(d).len()).sum::<usize>().max(1);
    let done = std::cell::Cell::new(0usize);
    let json = ctx.json;
    let mut on_step = |device: &str, check: &str| {
        if !json {
            let n = done.get();
            output::err_line(format_args!("[{:>2}/{total}] {} {device}: {check} ...", n + 1, bar(n, total)));
        }
    };
    let mut on_check = |c: &Check| {
        done.set(done.get() + 1);
        if json {
            output::json(&json!({"command": "commission", "check": c}));
        } else {
            let detail = if c.detail.is_empty() { String::new() } else { format!(" ({})", c.detail) };
            output::err_line(format_args!("        {} {}: {}{detail}", c.device, c.check, c.status.name()));
        }
    };
    let stop = || supervisor::stop_requested();
    let mut run = Run::new(ctx.clock.clone(), &ctx.link_text, &stop, &mut on_step, &mut on_check);
    run.dry_run = args.dry_run;
    run.halt_attempts = 1 + ctx.retry.read_retries;
    let mut ended = None;
    if !devices.is_empty() {
        match ctx.powercube() {
            Ok(pc) => {
                let mut cubes = Some(Cubes::new(pc));
                for (m, d) in devices {
                    if run.interrupted {
                        break;
                    }
                    let cs = match cubes.take() {
                        Some(c) => c,
                        None => Cubes::new(ctx.powercube()?),
                    };
                    let expected = expected_for(d, *m, files);
                    cubes = cube_plan::run_module(cs, *m, &d.address, d, expected, &mut run);
                }
            }
            Err(e) => ended = Some(format!("the PowerCube link could not be opened: {e:#}")),
        }
    }
    if run.interrupted {
        let why = supervisor::stop_reason().map_or_else(|| "stopped".to_string(), |r| r.to_string());
        ended = Some(format!("{why}: what moved was halted; later checks were not run"));
    }
    let duration_s = run.elapsed();
    let complete = ended.is_none();
    let (checks, backups, files) = (run.checks, run.backups, run.files);
    let mut report = Report {
        schema: report::SCHEMA,
        created_by: format!("axisctl {}", env!("AXISCTL_VERSION")),
        started: iso_utc(started),
        duration_s: (duration_s * 1000.0).round() / 1000.0,
        bench: ctx.link_text.clone(),
        complete,
        dry_run: args.dry_run,
        passed: false,
        summary: Default::default(),
        ended,
        motions,
        plan,
        checks,
    };
    report.settle();
    let doc = Document {
        schema: backup::SCHEMA.into(),
        created_by: report.created_by.clone(),
        link: ctx.link_text.clone(),
        devices: backups,
    };
    Ok((report, Files { backup: doc, recordings: files }))
}

/// What a run leaves besides its report: the final backup and the
/// recordings, (name, contents).
struct Files {
    backup: Document,
    recordings: Vec<(String, String)>,
}

fn bar(done: usize, total: usize) -> String {
    let width = 20;
    let full = done * width / total.max(1);
    format!("[{}{}]", "#".repeat(full), ".".repeat(width - full))
}

/// `2026-12-04T20:05:00Z`.
fn iso_utc(t: SystemTime) -> String {
    let s = axisctl::tui::snapshot::utc_stamp(t);
    // 20261204T200500Z
    format!("{}-{}-{}T{}:{}:{}Z", &s[0..4], &s[4..6], &s[6..8], &s[9..11], &s[11..13], &s[13..15])
}

fn write_report(out: &Path, report: &Report, files: Files) -> anyhow::Result<()> {
    let write = |name: &str, text: &str| -> anyhow::Result<()> {
        let path = out.join(name);
        std::fs::write(&path, text).map_err(|e| anyhow::anyhow!("writing {}: {e}", path.display()))
    };
    for (name, text) in &files.recordings {
        write(name, text)?;
    }
    if !files.backup.devices.is_empty() {
        write(BACKUP_FILE, &(serde_json::to_string_pretty(&files.backup)? + "\n"))?;
    }
    write("plan.toml", &report.plan.to_toml())?;
    write("report.json", &report.json())?;
    write("report.md", &report.markdown())?;
    write("report.html", &report.html())
}

fn print_summary(ctx: &Ctx, report: &Report, out: &Path) {
    let rows: Vec<Vec<String>> =
        std::iter::once(vec!["device".into(), "check".into(), "status".into(), "detail".into()])
            .chain(report.checks.iter().map(|c| {
                let failed: Vec<String> = c
                    .measured
                    .iter()
                    .filter(|m| !m.pass)
                    .map(|m| format!("{} {} (limit {})", m.name, m.value, m.limit))
                    .collect();
                let detail = if failed.is_empty() { c.detail.clone() } else { failed.join("; ") };
                vec![c.device.clone(), c.check.clone(), c.status.name().into(), detail]
            }))
            .collect();
    output::table(&rows, ctx.style);
    say!(
        "{} passed, {} failed, {} skipped{}; report in {}",
        report.summary.passed,
        report.summary.failed,
        report.summary.skipped,
        if report.complete { "" } else { " (INCOMPLETE)" },
        out.display()
    );
}

/// The default plan for every PowerCube module found: its identity and
/// limits as they are, homing, a move of a tenth of its range each way at
/// half its speed and acceleration inside its limits, with bands from the
/// ramp's own duration, and a halt test half-way into such a move.
fn default_plan(ctx: &Ctx) -> anyhow::Result<Plan> {
    let mut cubes = Cubes::new(ctx.powercube()?);
    let mut device = Vec::new();
    for m in cubes.present()? {
        let live = backup::powercube::capture(&mut cubes, m, &ctx.link_text)?;
        device.push(default_device(m, &live));
    }
    Ok(Plan { device })
}

fn default_device(m: ModuleId, live: &backup::Device) -> DevicePlan {
    let num = |n: &str| live.settings.get(n).and_then(|s| s.value.as_f64()).unwrap_or(f64::NAN);
    let text = |k: &str| live.identity.get(k).and_then(|v| v.as_str()).map(str::to_string);
    let (lo, hi) = (num("MinPos"), num("MaxPos"));
    let (vel, acc) = (sig(num("MaxVel") / 2.0), sig(num("MaxAcc") / 2.0));
    let distance = sig((hi - lo) / 10.0);
    // A trapezoid's duration (a triangle when the speed is never reached).
    let ramp = if distance >= vel * vel / acc { distance / vel + vel / acc } else { 2.0 * (distance / acc).sqrt() };
    let values = ["MinPos", "MaxPos", "MaxVel", "MaxAcc", "MaxCur"]
        .into_iter()
        .map(|n| (n.to_string(), axisctl::commission::plan::Expected { value: sig7(num(n)), tolerance: None }))
        .collect();
    let slack = sig(ramp + 1.0);
    DevicePlan {
        address: format!("powercube:{m}"),
        identity: Identity {
            kind: text("type"),
            serial: live.identity.get("serial").and_then(|v| v.as_u64()),
            firmware: text("version"),
        },
        settings: Some(Settings { backup: None, tolerance: 1e-6, values }),
        limits: true,
        home: Some(Home { timeout_s: 30.0 }),
        moves: Some(Moves {
            distance,
            window: [sig7(lo), sig7(hi)],
            vel: Some(vel),
            acc: Some(acc),
            band_percent: 2.0,
            timeout_s: sig(ramp * 3.0 + 5.0),
            rise_time_s: Some(Band::max(sig(ramp))),
            overshoot_percent: Some(Band::max(5.0)),
            settling_time_s: Some(Band::max(slack)),
            steady_state_error: Some(Band { min: Some(-sig(distance / 100.0)), max: Some(sig(distance / 100.0)) }),
            time_to_reach_s: Some(Band::max(slack)),
        }),
        halt: Some(axisctl::commission::plan::Halt {
            distance,
            after_s: sig(ramp / 2.0),
            standstill_s: Band::max(0.5),
        }),
        watchdog: false,
        backup: true,
    }
}

/// Three significant digits: a plan a person reads and edits.
fn sig(v: f64) -> f64 {
    format!("{v:.2e}").parse().unwrap_or(v)
}

/// Seven: a float setting as the module holds it (f32).
fn sig7(v: f64) -> f64 {
    format!("{v:.6e}").parse().unwrap_or(v)
}
