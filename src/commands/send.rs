//! `axisctl send`: one raw frame, as cansend sends it, for a technician
//! probing a device by hand. The frame is decoded and shown before it goes
//! out; one the decoder recognises as motion (or cannot decode) is refused
//! without `--force`; the frames that come back within `--listen` are
//! printed decoded. A PA-CONTROL command goes the way of `pac-raw`.

use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use axisctl::family::Family;
use axisctl::monitor::{describe_event, motion_of, FrameInfo};
use axisctl::proto::can_error::CanEvent;
use serde_json::json;

use super::{usage, Ctx};
use crate::cli::send::{Frame, SendArgs};
use crate::output::{self, say};

pub fn run(ctx: &Ctx, a: &SendArgs) -> anyhow::Result<()> {
    match a.parsed().map_err(usage)? {
        Frame::Line(family, text) => match &super::family_cli(family).line {
            Some(line) => (line.send)(ctx, &text, a.force),
            None => unreachable!("parsed only for a family with a line of its own"),
        },
        Frame::Can(frame) => {
            let event = CanEvent::Frame(frame);
            let sent = describe_event(&event);
            if !ctx.json {
                output::err_line(format_args!("-> {}", line(&frame.to_string(), &sent)));
            }
            if let Some(why) = motion_of(&frame) {
                if !a.force {
                    return Err(usage(format!(
                        "{frame}: {why}: not sent (--force sends it; nothing then stops it but you)"
                    )));
                }
            }
            let mut link = ctx.can_link()?;
            link.send(&frame)?;
            let mut answers = Vec::new();
            let deadline = Instant::now() + Duration::from_millis(a.listen);
            while let Some(left) = deadline.checked_duration_since(Instant::now()).filter(|d| !d.is_zero()) {
                let Some(event) = link.recv_event(left)? else { break };
                let text = match &event {
                    CanEvent::Frame(f) => f.to_string(),
                    CanEvent::Error(e) => e.to_string(),
                };
                let info = describe_event(&event);
                if !ctx.json {
                    say!("<- {}", line(&text, &info));
                }
                answers.push(frame_json(&text, &info, Some(now_secs())));
            }
            if ctx.json {
                output::json(&json!({"command": "send", "link": ctx.link_text, "motion": motion_of(&frame).is_some(),
                                     "sent": frame_json(&frame.to_string(), &sent, None), "answers": answers}));
            } else if answers.is_empty() {
                say!("no frame within {} ms", a.listen);
            }
            Ok(())
        }
    }
}

/// `0C3#0A3C  powercube:3  request  GetExtended ActPos`
fn line(frame: &str, i: &FrameInfo) -> String {
    let who = device(i).unwrap_or_else(|| "-".into());
    let problem = i.error.as_ref().map_or(String::new(), |e| format!(" ({e})"));
    format!("{frame:<24} {who:<12} {:<9} {}{problem}", i.kind, i.summary)
}

/// The frame's device in the one address form (`powercube:3`, `cdios:1/0`).
fn device(i: &FrameInfo) -> Option<String> {
    match (i.family, i.node, i.module) {
        (Some(Family::Cdios), Some(n), Some(m)) => Some(format!("cdios:{n}/{m}")),
        (Some(Family::Cdios), Some(n), None) => Some(format!("cdios:{n}")),
        (Some(f), _, Some(m)) => Some(format!("{}:{m}", f.name())),
        _ => None,
    }
}

/// A frame of the `send` document: no `family` key (that brings the
/// envelope of a device document); the device as its address.
fn frame_json(frame: &str, i: &FrameInfo, timestamp: Option<f64>) -> serde_json::Value {
    let mut v = json!({"frame": frame, "kind": i.kind, "summary": i.summary});
    if let Some(d) = device(i) {
        v["device"] = json!(d);
    }
    if !i.details.is_null() {
        v["details"] = i.details.clone();
    }
    if let Some(e) = &i.error {
        v["decode_error"] = json!(e);
    }
    if let Some(t) = timestamp {
        v["timestamp"] = json!(t);
    }
    v
}

fn now_secs() -> f64 {
    SystemTime::now().duration_since(UNIX_EPOCH).map_or(0.0, |d| d.as_secs_f64())
}
