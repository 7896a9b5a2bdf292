use std::cell::Cell;
use std::time::Duration;

use super::*;
use crate::clock::VirtualClock;

/// Counts its samples; each read takes `cost` of virtual time.
struct Fake<'a> {
    clock: &'a VirtualClock,
    cost: Duration,
    channels: Vec<Channel>,
    n: f64,
}

impl Sampler for Fake<'_> {
    fn channels(&self) -> &[Channel] {
        &self.channels
    }
    fn sample(&mut self) -> Result<Vec<f64>, RecordError> {
        self.clock.advance(self.cost);
        self.n += 1.0;
        Ok(vec![self.n])
    }
}

fn fake(clock: &VirtualClock, cost_ms: u64) -> Fake<'_> {
    let channels = vec![Channel { address: Address::Module(17), name: "ActPos".into(), unit: "m".into() }];
    Fake { clock, cost: Duration::from_millis(cost_ms), channels, n: 0.0 }
}

#[test]
fn count_takes_that_many_samples_back_to_back() {
    let clock = VirtualClock::new();
    let mut f = fake(&clock, 2);
    let mut got = Vec::new();
    let end = record(&mut f, &clock, None, Until::Count(5), &|| false, &mut |s, _| {
        got.push(s.clone());
        Ok(())
    })
    .unwrap();
    assert_eq!(end, End::Done);
    assert_eq!(got.iter().map(|s| s.seq).collect::<Vec<_>>(), [0, 1, 2, 3, 4]);
    let ts: Vec<f64> = got.iter().map(|s| (s.t * 1000.0).round()).collect();
    assert_eq!(ts, [0.0, 2.0, 4.0, 6.0, 8.0], "stamped when each sample's reads leave");
    assert_eq!(got[4].values, [5.0]);
}

#[test]
fn a_rate_spaces_the_samples_and_a_duration_ends_them() {
    let clock = VirtualClock::new();
    let mut f = fake(&clock, 1);
    let mut got = Vec::new();
    let period = Some(Duration::from_millis(10));
    let until = Until::Elapsed(Duration::from_millis(45));
    record(&mut f, &clock, period, until, &|| false, &mut |s, _| {
        got.push(s.t);
        Ok(())
    })
    .unwrap();
    let ms: Vec<f64> = got.iter().map(|t| (t * 1000.0).round()).collect();
    assert_eq!(ms, [0.0, 10.0, 20.0, 30.0, 40.0]);
}

#[test]
fn stop_ends_the_recording_between_samples() {
    let clock = VirtualClock::new();
    let mut f = fake(&clock, 1);
    let seen = Cell::new(0);
    let end = record(&mut f, &clock, None, Until::Stopped, &|| seen.get() >= 3, &mut |_, _| {
        seen.set(seen.get() + 1);
        Ok(())
    })
    .unwrap();
    assert_eq!((end, seen.get()), (End::Stopped, 3));
}
