//! Consecutive read lines of a batch on a CAN link, pipelined: the
//! requests of a group of lines leave in one burst and the answers come
//! back while the later requests are still on the wire, instead of each
//! line waiting for its answers before the next line's requests go out.
//!
//! A group is consecutive PowerCube `get-param` and `state` lines whose
//! requests are known before anything is sent ([`PipelinedRead`]), at
//! least two of them and at most [`MAX_BURST`] requests. Each line sends
//! exactly the frames its one-shot run sends and is shown by the one-shot's
//! own code from its answers, in line order; a read the burst did not
//! answer gets the session's retries on its own. Lines after a failing one
//! were read already, but print nothing and count as not run unless
//! `--keep-going`. Every other line, and every line on RS232, runs on its
//! own as before.
//!
//! A group that follows another at once leaves before that one's answers
//! are read, on the same session, so the bus is busy while the lines are
//! shown. The session hands each answer to the oldest burst still owed
//! one, so neither a late answer nor a retry's drain is taken for another
//! line's. A line between two groups runs on its own session, which knows
//! nothing of a burst out: the group after it waits for it.

use std::ops::Range;

use axisctl::device::powercube::Cubes;
use axisctl::family::Family;
use axisctl::open::Opener;
use axisctl::proto::powercube::{ModuleId, Request, Response};
use axisctl::session::powercube::Burst;
use axisctl::session::SessionError;

use super::{Engine, Line};
use crate::cli::Command;
use crate::commands::powercube::PipelinedRead;
use crate::commands::Ctx;

/// Requests in one burst at most: a real adapter's transmit queue is short
/// (the scan pipelines 31), and a request that waits in it longer than the
/// timeout would be counted as unanswered.
pub const MAX_BURST: usize = 32;

/// Which lines go out together, and the answers of the group whose burst
/// is out.
pub struct Pipeline {
    /// Per line, its requests when it can be pipelined.
    plans: Vec<Option<PipelinedRead>>,
    groups: Vec<Range<usize>>,
    sent: Option<Sent>,
    /// The next group's burst, sent on `sent`'s session before that
    /// group's answers were read.
    ahead: Option<(Range<usize>, Burst)>,
}

/// A group whose burst went out: its session (the retries use it) and each
/// line's answers, taken when the line is shown.
struct Sent {
    lines: Range<usize>,
    cubes: Cubes,
    answers: Vec<Option<Vec<Result<Response, SessionError>>>>,
}

/// A line's answers, ready to be shown.
pub struct Answered<'p> {
    read: &'p PipelinedRead,
    cubes: &'p mut Cubes,
    answers: Vec<Result<Response, SessionError>>,
}

impl Pipeline {
    /// Plans the groups of `lines` (the batch's lines, in order); none
    /// unless the link is CAN for the PowerCube family.
    pub fn new(ctx: &Ctx, lines: &[(usize, String, Line)]) -> Self {
        let can = ctx.given_link().ok().flatten().is_some_and(|spec| Opener::is_can(spec, Family::PowerCube));
        let plans: Vec<Option<PipelinedRead>> =
            lines.iter().map(|(_, _, line)| if can { plan(line) } else { None }).collect();
        let sizes: Vec<Option<usize>> = plans.iter().map(|p| p.as_ref().map(|p| p.requests().len())).collect();
        Self { groups: groups(&sizes, MAX_BURST), plans, sent: None, ahead: None }
    }

    /// The answers of line `i` (an index into the lines), when it belongs
    /// to a group; the group's burst goes out at its first line, unless it
    /// went out ahead. `None` also when the session could not be opened or
    /// the burst failed as a whole (the link): its lines then run on their
    /// own and say what failed.
    pub fn answered(&mut self, ctx: &Ctx, i: usize) -> Option<Answered<'_>> {
        let group = self.groups.iter().find(|g| g.contains(&i))?.clone();
        if group.start == i {
            self.sent = self.start(ctx, group.clone());
        }
        let sent = self.sent.as_mut().filter(|s| s.lines == group)?;
        let answers = sent.answers[i - group.start].take()?;
        Some(Answered { read: self.plans[i].as_ref()?, cubes: &mut sent.cubes, answers })
    }

    /// Reads `group`'s answers. The group that follows it at once goes out
    /// first, on the same session, so that it is on the wire while this
    /// group's lines are shown and the bus does not wait for the pty's turn
    /// around. The session gives each answer to the oldest burst still owed
    /// one, so a retry or a late answer cannot be taken for another line's.
    /// Only a group that follows at once goes ahead: a line in between runs
    /// on a session of its own, which knows nothing of a burst out.
    fn start(&mut self, ctx: &Ctx, group: Range<usize>) -> Option<Sent> {
        let previous = self.sent.take();
        let (reqs, counts) = requests(&self.plans, group.clone());
        let (mut cubes, burst) = match (self.ahead.take(), previous) {
            (Some((lines, burst)), Some(prev)) if lines == group => (prev.cubes, burst),
            _ => {
                let mut cubes = Cubes::new(ctx.powercube().ok()?);
                let burst = cubes.session().send_burst(&reqs).ok()?;
                (cubes, burst)
            }
        };
        if let Some(next) = self.groups.iter().find(|g| g.start == group.end).cloned() {
            if let Ok(b) = cubes.session().send_burst(&requests(&self.plans, next.clone()).0) {
                self.ahead = Some((next, b));
            }
        }
        let answers = match cubes.session().collect(burst) {
            Ok(c) => c.answers,
            Err(_) => {
                if let Some((_, b)) = self.ahead.take() {
                    cubes.session().abandon(b);
                }
                return None;
            }
        };
        let mut answers = answers.into_iter();
        let answers = counts.iter().map(|n| Some(answers.by_ref().take(*n).collect())).collect();
        Some(Sent { lines: group, cubes, answers })
    }
}

impl Answered<'_> {
    /// Shows the line from its answers, as its one-shot run would.
    fn finish(self, ctx: &Ctx) -> anyhow::Result<()> {
        self.read.finish(ctx, self.cubes, self.answers)
    }
}

fn plan(line: &Line) -> Option<PipelinedRead> {
    match line {
        Line::Run { command, .. } => match &**command {
            Command::PowerCube(c) => PipelinedRead::plan(c),
            _ => None,
        },
        Line::Text(_) => None,
    }
}

/// The requests of every line of `group`, in line order, and how many each line has.
fn requests(plans: &[Option<PipelinedRead>], group: Range<usize>) -> (Vec<(ModuleId, Request)>, Vec<usize>) {
    let per_line: Vec<Vec<(ModuleId, Request)>> = plans[group].iter().flatten().map(PipelinedRead::requests).collect();
    (per_line.iter().flatten().copied().collect(), per_line.iter().map(Vec::len).collect())
}

/// The groups among lines that can be pipelined (`Some(requests)`) or not
/// (`None`): runs of consecutive pipelinable lines, each cut where its
/// requests would exceed `cap`; a run of one line is no group (it runs on
/// its own), nor is a line of more than `cap` requests.
fn groups(sizes: &[Option<usize>], cap: usize) -> Vec<Range<usize>> {
    fn close(open: Option<(usize, usize)>, end: usize, out: &mut Vec<Range<usize>>) {
        if let Some((start, _)) = open.filter(|(start, _)| end - start >= 2) {
            out.push(start..end);
        }
    }
    let mut out = Vec::new();
    // The group being filled: its first line and its requests so far.
    let mut open: Option<(usize, usize)> = None;
    for (i, size) in sizes.iter().enumerate() {
        open = match (*size, open) {
            (Some(n), Some((start, total))) if total + n <= cap => Some((start, total + n)),
            (Some(n), _) if n <= cap => {
                close(open, i, &mut out);
                Some((i, n))
            }
            _ => {
                close(open, i, &mut out);
                None
            }
        };
    }
    close(open, sizes.len(), &mut out);
    out
}

impl Engine<'_> {
    /// Reports a line whose requests went out in its group's burst, as
    /// [`Engine::run`] reports a line.
    pub fn run_answered(&mut self, n: usize, text: &str, answered: Answered<'_>) -> Result<(), u8> {
        self.report(n, text, |ctx| answered.finish(ctx))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const R: Option<usize> = None;

    /// The groups as (first line, end).
    fn g(sizes: &[Option<usize>], cap: usize) -> Vec<(usize, usize)> {
        groups(sizes, cap).into_iter().map(|r| (r.start, r.end)).collect()
    }

    #[test]
    fn consecutive_reads_form_one_group_and_another_line_ends_it() {
        assert_eq!(g(&[Some(2), Some(2), Some(2)], 32), [(0, 3)]);
        assert_eq!(g(&[Some(2), Some(2), R, Some(2), Some(4)], 32), [(0, 2), (3, 5)]);
        assert_eq!(g(&[R, Some(2), Some(2), R], 32), [(1, 3)]);
    }

    #[test]
    fn a_lone_read_is_no_group() {
        assert_eq!(g(&[Some(2), R, Some(2)], 32), []);
        assert_eq!(g(&[Some(2)], 32), []);
        assert_eq!(g(&[], 32), []);
    }

    #[test]
    fn a_group_holds_at_most_the_cap_of_requests() {
        // 17 lines of 2 requests: 16 fill a burst of 32, the 17th is alone.
        assert_eq!(g(&[Some(2); 17], 32), [(0, 16)]);
        assert_eq!(g(&[Some(2); 34], 32), [(0, 16), (16, 32), (32, 34)]);
        assert_eq!(g(&[Some(30), Some(2), Some(2), Some(31)], 32), [(0, 2)]);
        assert_eq!(g(&[Some(3); 3], 8), [(0, 2)]);
    }

    #[test]
    fn a_line_of_more_requests_than_the_cap_runs_on_its_own() {
        assert_eq!(g(&[Some(2), Some(33), Some(2), Some(2)], 32), [(2, 4)]);
        assert_eq!(g(&[Some(33), Some(33)], 32), []);
    }

    /// The requests of a line that can be pipelined; `None` for one that
    /// runs on its own.
    fn requests(line: &str) -> Option<usize> {
        use clap::Parser;
        let cli = crate::cli::Cli::try_parse_from(std::iter::once("axisctl").chain(line.split_whitespace())).unwrap();
        plan(&Line::Run { command: Box::new(cli.command), name: String::new() }).map(|p| p.requests().len())
    }

    #[test]
    fn get_param_of_named_modules_and_parameters_is_pipelined_with_its_config_read() {
        assert_eq!(requests("get-param -m 3 ActPos"), Some(2));
        assert_eq!(requests("get-param -m 17 ActPos ActVel Config"), Some(4));
        assert_eq!(requests("get-param -m 3,5,17 ActPos"), Some(6));
    }

    #[test]
    fn state_of_named_modules_is_pipelined() {
        assert_eq!(requests("state -m 3"), Some(1));
        assert_eq!(requests("state -m 3,5"), Some(2));
        assert_eq!(requests("state -m all"), None, "asks who is present first");
    }

    #[test]
    fn reads_that_ask_the_module_first_and_every_other_line_run_on_their_own() {
        assert_eq!(requests("get-param -m all ActPos"), None, "asks who is present first");
        assert_eq!(requests("get-param -m 3 --all"), None, "reads the firmware version first");
        assert_eq!(requests("get-param -m 3 ActFTemp"), None, "reads the firmware version first");
        assert_eq!(requests("get-param -m 3 NoSuchParam"), None, "refused alone, with its message");
        assert_eq!(requests("info -m 3"), None);
        assert_eq!(requests("get-config -m 3"), None);
        assert_eq!(requests("move-vel -m 3 0.1"), None);
        assert_eq!(requests("pac-state"), None);
    }
}
