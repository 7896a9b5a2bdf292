//! Several samplers as one: the devices of a recording over several links
//! or families (`record powercube:3.ActPos pac:2.position`). Each sample
//! reads every sampler in turn and is stamped once, when its first request
//! leaves: one time base for every device of the bench.

use super::{Channel, RecordError, Sampler};

/// The samplers of a recording, read in the order given.
pub struct Several {
    parts: Vec<Box<dyn Sampler>>,
    channels: Vec<Channel>,
}

impl Several {
    pub fn new(parts: Vec<Box<dyn Sampler>>) -> Self {
        let channels = parts.iter().flat_map(|p| p.channels().iter().cloned()).collect();
        Self { parts, channels }
    }
}

impl Sampler for Several {
    fn channels(&self) -> &[Channel] {
        &self.channels
    }

    /// Every part's values, in the parts' order. A part that fails fails
    /// the sample: a recording never holds a row with a hole it did not say.
    fn sample(&mut self) -> Result<Vec<f64>, RecordError> {
        let mut out = Vec::with_capacity(self.channels.len());
        for p in &mut self.parts {
            out.extend(p.sample()?);
        }
        Ok(out)
    }

    // No `back_to_back` and no `read_at`: with requests sent ahead on one
    // link while another is read, a sample's stamp would belong to no
    // device; each sample is stamped when it is called, before its first
    // request leaves.

    fn finish(&mut self) {
        for p in &mut self.parts {
            p.finish();
        }
    }
}

#[cfg(test)]
mod tests {
    use std::time::Duration;

    use super::*;
    use crate::clock::{Clock, VirtualClock};
    use crate::record::{record, Address, Until};

    /// A sampler of one channel whose reading takes `cost` of a virtual clock.
    struct Slow {
        channels: Vec<Channel>,
        clock: std::sync::Arc<VirtualClock>,
        cost: Duration,
        value: f64,
    }

    impl Sampler for Slow {
        fn channels(&self) -> &[Channel] {
            &self.channels
        }
        fn sample(&mut self) -> Result<Vec<f64>, RecordError> {
            self.clock.advance(self.cost);
            self.value += 1.0;
            Ok(vec![self.value])
        }
        fn back_to_back(&mut self) {
            panic!("a part of several samplers never sends ahead");
        }
    }

    fn slow(clock: &std::sync::Arc<VirtualClock>, at: Address, ms: u64, value: f64) -> Box<Slow> {
        let channels = vec![Channel { address: at, name: "v".into(), unit: "m".into() }];
        Box::new(Slow { channels, clock: clock.clone(), cost: Duration::from_millis(ms), value })
    }

    #[test]
    fn one_row_per_sample_every_part_in_order_stamped_when_called() {
        let clock = std::sync::Arc::new(VirtualClock::new());
        let parts: Vec<Box<dyn Sampler>> = vec![
            slow(&clock, Address::PowerCube { module: 3 }, 3, 0.0),
            slow(&clock, Address::Pac { axis: Some(2) }, 7, 100.0),
        ];
        let mut s = Several::new(parts);
        assert_eq!(
            s.channels().iter().map(|c| c.address).collect::<Vec<_>>(),
            [Address::PowerCube { module: 3 }, Address::Pac { axis: Some(2) }]
        );
        let mut rows = Vec::new();
        let ended = record(
            &mut s,
            clock.as_ref() as &dyn Clock,
            crate::record::Pace::from_period(None),
            Until::Count(3),
            &|| false,
            &mut |smp, _| {
                rows.push((smp.t, smp.seq, smp.values.clone()));
                Ok(())
            },
        );
        assert!(ended.is_ok());
        // Each sample costs 3 + 7 ms; it is stamped before the first part reads.
        assert_eq!(rows, [(0.0, 0, vec![1.0, 101.0]), (0.01, 1, vec![2.0, 102.0]), (0.02, 2, vec![3.0, 103.0])]);
    }
}
