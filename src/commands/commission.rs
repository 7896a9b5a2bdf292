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
use axisctl::commission::devices::{self, Planned};
use axisctl::commission::plan::{DevicePlan, Plan};
use axisctl::commission::report::{self, Check, Report};
use axisctl::commission::{Run, BACKUP_FILE};
use axisctl::device::supervisor;
use serde_json::json;

mod out_dir;

use super::{usage, Ctx, DeviceFault, Interrupted, NoAnswer, OnBench};
use crate::cli::commission::CommissionArgs;
use crate::output::{self, say};

pub fn run(ctx: &Ctx, args: CommissionArgs) -> anyhow::Result<()> {
    // `-d`: the devices named, each checked before anything opens.
    let only = named(ctx, &args.device)?;
    if args.print_plan {
        let plan = default_plan(ctx, &only)?;
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
        Some(p) => (of_plan(ctx, read_plan(p)?, &only, p)?, p.parent().map(Path::to_path_buf).unwrap_or_default()),
        None => (default_plan(ctx, &only)?, PathBuf::new()),
    };
    // Every address and file of the plan is checked before anything is sent.
    let devices = devices::resolve(ctx.bench()?, &plan).map_err(usage)?;
    let files = expected_files(&plan, &plan_dir)?;
    std::fs::create_dir_all(&out).map_err(|e| usage(format!("--out {}: {e}", out.display())))?;
    let motions = devices::motions(&devices);
    if args.dry_run {
        list("The plan would make these motions (not made: --dry-run):", &motions);
    } else if !motions.is_empty() {
        confirm(&motions, args.yes)?;
        super::arm_interrupt()?;
    }
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
    devices: &[Planned],
    files: &[(PathBuf, Document)],
    motions: Vec<String>,
) -> anyhow::Result<(Report, Files)> {
    let started = SystemTime::now();
    let total = devices.iter().map(|d| devices::planned(d).len()).sum::<usize>().max(1);
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
    run.retry = ctx.retry;
    run.links = axisctl::device::registry::FACES.into_iter().map(|f| (f, ctx.link_text_for(f))).collect();
    // A PowerCube bus and a Cdios node on one adapter share it.
    ctx.opener().keep_links_open();
    let mut ended = devices::run_all(&mut OnBench(ctx), devices, files, &mut run).err();
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

/// The devices `commission -d` names, in the order given and each once;
/// each family is then run on the link its devices are on.
fn named(ctx: &Ctx, refs: &[DeviceRef]) -> anyhow::Result<Vec<Address>> {
    if refs.is_empty() {
        return Ok(Vec::new());
    }
    let named = super::devices::any_family(ctx, refs)?;
    super::devices::pin_families(ctx, &named)?;
    Ok(named.into_iter().map(|(at, _)| at).collect())
}

/// The plan's devices that `only` names (the whole plan when it names
/// none). A device named that the plan does not have is a usage error
/// before anything is sent; an entry that names no device of the bench is
/// kept, so that the plan's check refuses it as it would without `-d`.
fn of_plan(ctx: &Ctx, mut plan: Plan, only: &[Address], path: &Path) -> anyhow::Result<Plan> {
    if only.is_empty() {
        return Ok(plan);
    }
    let bench = ctx.bench()?;
    let at = |d: &DevicePlan| d.address.parse().ok().and_then(|r: DeviceRef| bench.resolve(&r).ok());
    if let Some(absent) = only.iter().find(|a| !plan.device.iter().any(|d| at(d) == Some(**a))) {
        let held: Vec<&str> = plan.device.iter().map(|d| d.address.as_str()).collect();
        return Err(usage(format!(
            "{absent} is not a device of the plan {}; nothing was sent (it plans {})",
            path.display(),
            if held.is_empty() { "none".into() } else { held.join(", ") }
        )));
    }
    plan.device.retain(|d| at(d).is_none_or(|a| only.contains(&a)));
    Ok(plan)
}

/// The default plan for every device of every family the bench carries,
/// or for the devices `only` names: one that was not found has no plan and
/// is said (exit 4) before anything moves.
fn default_plan(ctx: &Ctx, only: &[Address]) -> anyhow::Result<Plan> {
    ctx.opener().keep_links_open();
    let link = |f| ctx.link_text_for(f);
    let plan = devices::default_plan(ctx.bench()?, &mut OnBench(ctx), &link, only).map_err(|e| match e {
        axisctl::commission::DefaultPlanError::Open(e) => e,
        axisctl::commission::DefaultPlanError::Read(e) => e.into(),
    })?;
    let planned = |a: &Address| plan.device.iter().any(|d| d.address.parse().is_ok_and(|p: Address| p == *a));
    let absent: Vec<String> = only.iter().filter(|a| !planned(a)).map(|a| a.to_string()).collect();
    if !absent.is_empty() {
        return Err(NoAnswer(format!(
            "not found on the bench, so not planned: {}; nothing was moved",
            absent.join(", ")
        ))
        .into());
    }
    Ok(plan)
}
