use std::process::ExitCode;

use std::io::Write;

use axisctl::device::supervisor;
use axisctl::session::ErrorKind;

mod cli;
mod commands;
mod output;

fn main() -> ExitCode {
    // First of all: a panic on any thread from here on halts a supervised
    // motion, and a write past `ulimit -f` fails (and is reported) instead of
    // killing the process.
    supervisor::install_panic_hook();
    supervisor::ignore_file_size_signal();
    // A shell asking for completions (the script of `axisctl completions`):
    // answered from the parser and the tables, then the process ends.
    cli::complete::answer_shell(|| cli::command(&commands::exit::summary()));
    axisctl::link::lock::on_notice(|text| {
        let _ = writeln!(std::io::stderr(), "axisctl: {text}");
    });
    let cli = match cli::parse(&commands::exit::summary()) {
        Ok(cli) => cli,
        Err(e) => {
            let code = if e.use_stderr() { commands::exit::code(ErrorKind::Usage) } else { commands::exit::SUCCESS };
            if e.use_stderr() && json_requested() {
                let _ = writeln!(std::io::stderr(), "{}", commands::error_json::usage(&e, code));
                return ExitCode::from(code);
            }
            // One error style: clap's "error: ..." is said as every other
            // error of the tool is, "axisctl: ...".
            if e.use_stderr() {
                let text = e.render().to_string();
                let text = text.strip_prefix("error: ").map_or(text.clone(), |rest| format!("axisctl: {rest}"));
                let _ = write!(std::io::stderr(), "{text}");
                return ExitCode::from(code);
            }
            // Help and version go to stdout: a full disk fails them like any
            // output; a reader that went away does not.
            return match e.print() {
                Err(io) if !e.use_stderr() && io.kind() != std::io::ErrorKind::BrokenPipe => {
                    let _ = writeln!(std::io::stderr(), "axisctl: cannot write the output: {io}");
                    ExitCode::from(commands::exit::code(ErrorKind::Other))
                }
                _ => ExitCode::from(code),
            };
        }
    };
    let json = cli.global.json;
    output::set_quiet(cli.global.quiet);
    let result = commands::run(cli);
    output::flush();
    let code = finish(result, json);
    // Ctrl-Z (or a background job that used its terminal) during a
    // supervised motion: what it moved is halted and its links are closed
    // by now, so the process stops as asked. Continued, it exits: the
    // motion is not resumed.
    if let Some(sig) = supervisor::job_stop() {
        if !json {
            let name = supervisor::signal_name(sig);
            let _ = writeln!(
                std::io::stderr(),
                "axisctl: {name}: stopping; continued, axisctl ends (the motion is not resumed)"
            );
        }
        supervisor::suspend_if_asked();
    }
    code
}

/// Reports the command's result, and the exit code it asks for.
fn finish(result: anyhow::Result<()>, json: bool) -> ExitCode {
    match result {
        // The traffic log never fails the traffic (a halt must not wait for
        // it), so a log that could not be written is reported here.
        Ok(()) => match (supervisor::log_failure(), output::failure()) {
            (Some(e), _) => {
                let _ = writeln!(std::io::stderr(), "axisctl: cannot write the --log file: {e}");
                ExitCode::from(commands::exit::code(ErrorKind::Other))
            }
            // The reader went away (`| head`): the convention of Unix tools
            // is to end quietly.
            (None, Some((std::io::ErrorKind::BrokenPipe, _))) | (None, None) => ExitCode::SUCCESS,
            // A full disk or a failing device: the output is lost, so the
            // command failed, even though the device did its part.
            (None, Some((_, e))) => {
                let _ = writeln!(std::io::stderr(), "axisctl: cannot write the output: {e}");
                ExitCode::from(commands::exit::code(ErrorKind::Other))
            }
        },
        Err(e) if is_broken_pipe(&e) => ExitCode::SUCCESS,
        Err(e) if e.is::<commands::Reported>() => {
            ExitCode::from(e.downcast_ref::<commands::Reported>().map_or(1, |r| r.0))
        }
        Err(e) => {
            let (e, kind, code) = commands::exit::classify_failure(e);
            if json {
                let refusal = commands::refusal(&e);
                let doc = commands::error_json::failure(
                    kind.as_str(),
                    code,
                    commands::error_json::message(&e),
                    refusal.as_ref(),
                );
                let _ = writeln!(std::io::stderr(), "{doc}");
            } else {
                let _ = writeln!(std::io::stderr(), "axisctl: {}", commands::error_json::message(&e));
            }
            ExitCode::from(code)
        }
    }
}

/// `--json` on a command line clap could not parse: the error must still
/// be the JSON object a script expects (everything after `--` is a value).
fn json_requested() -> bool {
    std::env::args_os().skip(1).take_while(|a| a != "--").any(|a| a == "--json")
}

fn is_broken_pipe(e: &anyhow::Error) -> bool {
    e.chain().filter_map(|c| c.downcast_ref::<std::io::Error>()).any(|io| io.kind() == std::io::ErrorKind::BrokenPipe)
}
