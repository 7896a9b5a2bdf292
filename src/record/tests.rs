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

const BACK_TO_BACK: Pace = Pace::BackToBack { min_gap: Duration::ZERO };

fn fake(clock: &VirtualClock, cost_ms: u64) -> Fake<'_> {
    let channels =
        vec![Channel { address: Address::PowerCube { module: 17 }, name: "ActPos".into(), unit: "m".into() }];
    Fake { clock, cost: Duration::from_millis(cost_ms), channels, n: 0.0 }
}

#[test]
fn count_takes_that_many_samples_back_to_back() {
    let clock = VirtualClock::new();
    let mut f = fake(&clock, 2);
    let mut got = Vec::new();
    let end = record(&mut f, &clock, BACK_TO_BACK, Until::Count(5), &|| false, &mut |s, _| {
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
    let period = Pace::Every(Duration::from_millis(10));
    let until = Until::Elapsed(Duration::from_millis(45));
    record(&mut f, &clock, period, until, &|| false, &mut |s, _| {
        got.push(s.t);
        Ok(())
    })
    .unwrap();
    let ms: Vec<f64> = got.iter().map(|t| (t * 1000.0).round()).collect();
    assert_eq!(ms, [0.0, 10.0, 20.0, 30.0, 40.0]);
}

// Back to back with a gap: a sampler that answers at once is waited for,
// one that takes longer than the gap is not.
#[test]
fn back_to_back_samples_keep_at_least_the_gap() {
    for (cost_ms, want) in [(0, [0.0, 1.0, 2.0, 3.0]), (2, [0.0, 2.0, 4.0, 6.0])] {
        let clock = VirtualClock::new();
        let mut f = fake(&clock, cost_ms);
        let mut ms = Vec::new();
        let pace = Pace::BackToBack { min_gap: Duration::from_millis(1) };
        record(&mut f, &clock, pace, Until::Count(4), &|| false, &mut |s, _| {
            ms.push((s.t * 1000.0).round());
            Ok(())
        })
        .unwrap();
        assert_eq!(ms, want, "reads taking {cost_ms} ms");
    }
}

#[test]
fn stop_ends_the_recording_between_samples() {
    let clock = VirtualClock::new();
    let mut f = fake(&clock, 1);
    let seen = Cell::new(0);
    let end = record(&mut f, &clock, BACK_TO_BACK, Until::Stopped, &|| seen.get() >= 3, &mut |_, _| {
        seen.set(seen.get() + 1);
        Ok(())
    })
    .unwrap();
    assert_eq!((end, seen.get()), (End::Stopped, 3));
}

/// Says what `record` asked of it; its reads are stamped `read_ms` after each call.
struct Ahead<'a> {
    clock: &'a VirtualClock,
    channels: Vec<Channel>,
    read_ms: Vec<u64>,
    calls: usize,
    back_to_back: bool,
    finished: bool,
    read_at: Option<std::time::Instant>,
}

impl Sampler for Ahead<'_> {
    fn channels(&self) -> &[Channel] {
        &self.channels
    }
    fn sample(&mut self) -> Result<Vec<f64>, RecordError> {
        let at = self.clock.now();
        self.read_at = Some(at + Duration::from_millis(self.read_ms[self.calls]));
        self.clock.advance(Duration::from_millis(10));
        self.calls += 1;
        Ok(vec![0.0])
    }
    fn back_to_back(&mut self) {
        self.back_to_back = true;
    }
    fn read_at(&self) -> Option<std::time::Instant> {
        self.read_at
    }
    fn finish(&mut self) {
        self.finished = true;
    }
}

fn ahead(clock: &VirtualClock, read_ms: Vec<u64>) -> Ahead<'_> {
    let channels =
        vec![Channel { address: Address::PowerCube { module: 3 }, name: "ActPos".into(), unit: "rad".into() }];
    Ahead { clock, channels, read_ms, calls: 0, back_to_back: false, finished: false, read_at: None }
}

// Back to back a sample is stamped when its devices read it, as the
// sampler says; a stamp that would go back (a burst whose answers all came
// by retry) is held at the one before.
#[test]
fn back_to_back_samples_are_stamped_when_read_and_never_go_back() {
    let clock = VirtualClock::new();
    let mut s = ahead(&clock, vec![2, 1, 0, 3]);
    let mut ms = Vec::new();
    record(&mut s, &clock, BACK_TO_BACK, Until::Count(4), &|| false, &mut |x, _| {
        ms.push((x.t * 1000.0).round());
        Ok(())
    })
    .unwrap();
    assert!(s.back_to_back && s.finished);
    assert_eq!(ms, [2.0, 11.0, 20.0, 33.0]);
    // The second read claims 10 ms, before the first one's 15 ms.
    let clock = VirtualClock::new();
    let mut s = ahead(&clock, vec![15, 0]);
    let mut ms = Vec::new();
    record(&mut s, &clock, BACK_TO_BACK, Until::Count(2), &|| false, &mut |x, _| {
        ms.push((x.t * 1000.0).round());
        Ok(())
    })
    .unwrap();
    assert_eq!(ms, [15.0, 15.0]);
}

// With a rate every sample is read when it is due: nothing is sent ahead,
// and the stamp is the time of the call. The recording's end is told to the
// sampler on every way out, an error included.
#[test]
fn with_a_rate_nothing_is_sent_ahead_and_every_end_is_told() {
    let clock = VirtualClock::new();
    let mut s = ahead(&clock, vec![0; 3]);
    let period = Pace::Every(Duration::from_millis(20));
    record(&mut s, &clock, period, Until::Count(3), &|| false, &mut |_, _| Ok(())).unwrap();
    assert!(!s.back_to_back && s.finished);
    let mut s = ahead(&clock, vec![0; 3]);
    let failed = record(&mut s, &clock, BACK_TO_BACK, Until::Stopped, &|| false, &mut |_, _| {
        Err(RecordError::from(crate::device::powercube::Error::Refused("full".into())))
    });
    assert!(failed.is_err());
    assert!(s.finished, "the burst in flight is abandoned after an error too");
}

// A value is named as the command line types it, case aside; an unknown
// name is none.
#[test]
fn values_are_found_by_name_case_aside() {
    use crate::record::cdios::CdiosValue;
    use crate::record::pac::PacValue;
    assert_eq!(PacValue::parse("Speed"), Some(PacValue::Speed));
    assert_eq!(PacValue::parse("STATUS"), Some(PacValue::Status));
    assert_eq!(CdiosValue::parse("position"), Some(CdiosValue::Position));
    assert_eq!(PacValue::parse("ActPos"), None);
}
