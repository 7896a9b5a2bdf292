//! Cdios node tests on virtual time. Frames are the manual's byte tables
//! (section per command code) on the README's ids: commands to 0x201,
//! answers from 0x181, NMT on 0.

use std::time::{Duration, Instant};

use super::*;
use crate::proto::CanFrame;

fn f(s: &str) -> CanFrame {
    s.parse().unwrap()
}

struct Rig {
    node: CdiosNode,
    now: Instant,
}

impl Rig {
    fn new() -> Self {
        let now = Instant::now();
        Self { node: CdiosNode::contract(now), now }
    }

    fn started() -> Self {
        let mut r = Self::new();
        assert!(r.send("000#0101").is_empty(), "NMT is not answered");
        r
    }

    fn send(&mut self, frame: &str) -> Vec<String> {
        let mut out = Vec::new();
        self.node.handle_can(self.now, &f(frame), &mut out);
        out.iter().map(ToString::to_string).collect()
    }

    fn wait(&mut self, d: Duration) -> Vec<String> {
        self.now += d;
        let mut out = Vec::new();
        self.node.poll(self.now, &mut out);
        out.iter().map(ToString::to_string).collect()
    }
}

// Specs README: commands only after NMT start `000#0101`.
#[test]
fn nmt_start_required() {
    let mut r = Rig::new();
    assert!(r.send("201#2600000000000000").is_empty());
    r.send("000#0101");
    assert_eq!(
        r.send("201#2600000000000000"),
        ["181#2600000000009000"],
        "ready input active, position not initialised"
    );
}
