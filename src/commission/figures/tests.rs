//! Figures measured on synthetic responses whose true figures are known in
//! closed form, sampled at 1 ms unless said.

use proptest::prelude::*;

use super::*;

fn sampled(dt: f64, until: f64, f: impl Fn(f64) -> f64) -> (Vec<f64>, Vec<f64>) {
    let n = (until / dt).round() as usize;
    let t: Vec<f64> = (0..=n).map(|i| i as f64 * dt).collect();
    let y = t.iter().map(|&t| f(t)).collect();
    (t, y)
}

fn close(got: f64, want: f64, tol: f64, what: &str) {
    assert!((got - want).abs() <= tol, "{what}: measured {got}, true {want} (tolerance {tol})");
}

#[test]
fn first_order_from_its_time_constant() {
    // y = 2 + 3 (1 - e^(-t/tau)): rise 10-90 % = tau ln 9, 2 % band reached
    // (and settled) at tau ln 50, no overshoot.
    let tau = 0.2;
    let (t, y) = sampled(0.001, 3.0, |t| 2.0 + 3.0 * (1.0 - (-t / tau).exp()));
    let f = step(&t, &y, 5.0, 0.02).unwrap();
    close(f.rise_time.unwrap(), tau * 9f64.ln(), 1e-4, "rise time");
    close(f.settling_time.unwrap(), tau * 50f64.ln(), 1e-4, "settling time");
    close(f.time_to_reach.unwrap(), tau * 50f64.ln(), 1e-4, "time to reach");
    assert_eq!(f.overshoot_percent, 0.0);
    close(f.steady_state_error, 0.0, 1e-5, "steady-state error");
    close(f.peak, y[y.len() - 1], 1e-12, "peak");
}

#[test]
fn second_order_underdamped_overshoot_and_peak_time() {
    // Unit step of wn = 10 rad/s, zeta = 0.3: overshoot e^(-zeta pi / sqrt(1 - zeta^2)),
    // peak at pi / wd. Settling to 2 % is found against the exact envelope
    // crossing by bisection on a fine sample.
    let (wn, z) = (10.0f64, 0.3f64);
    let wd = wn * (1.0 - z * z).sqrt();
    let phi = (z / (1.0 - z * z).sqrt()).atan();
    let resp = |t: f64| 1.0 - (-z * wn * t).exp() * ((wd * t).cos() + (wd * t).sin() * phi.tan());
    let (t, y) = sampled(0.0005, 4.0, resp);
    let f = step(&t, &y, 1.0, 0.02).unwrap();
    let overshoot = 100.0 * (-z * std::f64::consts::PI / (1.0 - z * z).sqrt()).exp();
    close(f.overshoot_percent, overshoot, 0.01, "overshoot %");
    close(f.time_to_peak, std::f64::consts::PI / wd, 0.001, "time to peak");
    close(f.peak, 1.0 + overshoot / 100.0, 1e-4, "peak");
    // The last exit from the band, found on a 10 us grid.
    let mut fine = (0..400_000).map(|i| i as f64 * 1e-5);
    let last_out = fine.rfind(|&t| (resp(t) - 1.0).abs() > 0.02).unwrap();
    close(f.settling_time.unwrap(), last_out, 0.001, "settling time");
    // The first entry into the band is on the first rise, before the peak.
    assert!(f.time_to_reach.unwrap() < f.time_to_peak);
    assert!(f.settling_time.unwrap() > f.time_to_peak, "it leaves the band after the first entry");
    close(f.steady_state_error, 0.0, 1e-4, "steady-state error");
}

#[test]
fn a_ramp_to_the_target_and_hold() {
    // A linear ramp over T then a hold: rise 0.8 T, band b reached at (1 - b) T,
    // no overshoot; a downward step of -4 units measures the same.
    let big_t = 1.5;
    let (t, y) = sampled(0.002, 3.0, |t| 1.0 - 4.0 * (t / big_t).min(1.0));
    let f = step(&t, &y, -3.0, 0.05).unwrap();
    close(f.rise_time.unwrap(), 0.8 * big_t, 1e-9, "rise time");
    close(f.time_to_reach.unwrap(), 0.95 * big_t, 1e-9, "time to reach");
    close(f.settling_time.unwrap(), 0.95 * big_t, 1e-9, "settling time");
    assert_eq!(f.overshoot_percent, 0.0);
    assert_eq!(f.peak, -3.0, "the peak is farthest in the step's direction");
}

#[test]
fn a_response_that_stops_short_has_its_error_and_no_settling() {
    // A first-order response to 95 % of the step: steady-state error -5 % of
    // the step, never inside a 2 % band, never 90 %... it does reach 90 %.
    let (t, y) = sampled(0.001, 2.0, |t| 0.95 * (1.0 - (-t / 0.1).exp()));
    let f = step(&t, &y, 1.0, 0.02).unwrap();
    close(f.steady_state_error, -0.05, 1e-4, "steady-state error");
    assert_eq!(f.settling_time, None);
    assert_eq!(f.time_to_reach, None);
    // 10 % and 90 % of the step are 0.1/0.95 and 0.9/0.95 of its own end.
    let want = 0.1 * ((1.0f64 - 0.1 / 0.95) / (1.0 - 0.9 / 0.95)).ln();
    close(f.rise_time.unwrap(), want, 1e-4, "rise time");
    let (t, y) = sampled(0.001, 2.0, |t| 0.5 * t.min(1.0));
    assert_eq!(step(&t, &y, 1.0, 0.02).unwrap().rise_time, None, "never reaches 90 %");
}

#[test]
fn noise_averages_out_of_the_steady_state_error() {
    // A first-order step with +-1 % uniform noise from a fixed generator:
    // the figures stay within the noise's reach of the true ones.
    let mut state = 0x2545_f491_4f6c_dd1du64;
    let mut noise = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state as f64 / u64::MAX as f64 - 0.5) * 0.02
    };
    let tau = 0.3;
    let (t, clean) = sampled(0.002, 4.0, |t| 1.0 - (-t / tau).exp());
    let y: Vec<f64> = clean.iter().map(|v| v + noise()).collect();
    let f = step(&t, &y, 1.0, 0.05).unwrap();
    close(f.rise_time.unwrap(), tau * 9f64.ln(), 0.03, "rise time");
    // With +-1 % of noise the response last leaves the 5 % band while the
    // clean curve is between 4 % and 6 % short of the target.
    let settle = f.settling_time.unwrap();
    assert!((tau * (1.0f64 / 0.06).ln()..=tau * 25f64.ln()).contains(&settle), "settling time {settle}");
    close(f.steady_state_error, 0.0, 0.003, "steady-state error");
    assert!(f.overshoot_percent <= 1.0 + 1e-9, "only the noise passes the target: {}", f.overshoot_percent);
}

#[test]
fn uneven_and_repeated_stamps_interpolate() {
    // Two samples answered by one burst share a stamp.
    let t = [0.0, 0.1, 0.1, 0.3, 0.4, 1.0];
    let y = [0.0, 0.2, 0.4, 0.8, 1.0, 1.0];
    let f = step(&t, &y, 1.0, 0.02).unwrap();
    // 10 % at t 0.05; 90 % between (0.3, 0.8) and (0.4, 1.0): 0.35.
    close(f.rise_time.unwrap(), 0.30, 1e-12, "rise time");
    close(f.time_to_reach.unwrap(), 0.39, 1e-12, "time to reach");
}

#[test]
fn degenerate_inputs_are_typed_errors() {
    assert_eq!(step(&[], &[], 1.0, 0.02), Err(FigureError::Empty));
    assert_eq!(step(&[0.0], &[0.0, 1.0], 1.0, 0.02), Err(FigureError::Lengths { times: 1, values: 2 }));
    assert_eq!(step(&[0.0, 1.0], &[2.0, 2.0], 2.0, 0.02), Err(FigureError::NoStep), "a constant at its target");
    assert_eq!(step(&[0.0, 1.0, 0.5], &[0.0, 0.5, 1.0], 1.0, 0.02), Err(FigureError::TimeBack { index: 2 }));
    assert_eq!(step(&[0.0, 1.0], &[0.0, f64::NAN], 1.0, 0.02), Err(FigureError::NotFinite { index: 1 }));
    assert_eq!(step(&[0.0, f64::INFINITY], &[0.0, 1.0], 1.0, 0.02), Err(FigureError::NotFinite { index: 1 }));
    assert_eq!(step(&[0.0, 1.0], &[0.0, 1.0], f64::NAN, 0.02), Err(FigureError::NotFinite { index: 0 }));
    for band in [0.0, 1.0, -0.1, f64::NAN] {
        assert!(matches!(step(&[0.0, 1.0], &[0.0, 1.0], 1.0, band), Err(FigureError::Band(_))), "band {band}");
    }
    assert_eq!(peak_abs(&[], &[]), Err(FigureError::Empty));
    // A constant short of its target: measured, it never gets there.
    let f = step(&[0.0, 1.0, 2.0], &[0.0, 0.0, 0.0], 1.0, 0.02).unwrap();
    assert_eq!((f.rise_time, f.settling_time, f.time_to_reach), (None, None, None));
    assert_eq!(f.steady_state_error, -1.0);
    // One sample, already off the target.
    assert!(step(&[0.0], &[0.0], 1.0, 0.02).is_ok());
}

#[test]
fn peak_of_a_signed_signal() {
    assert_eq!(peak_abs(&[1.0, 2.0, 3.0], &[0.5, -2.0, 1.0]), Ok((2.0, 1.0)));
}

proptest! {
    /// Any input gives figures or a typed error, never a panic; figures
    /// of a valid step keep their order (reach before settle, rise within
    /// the recording).
    #[test]
    fn never_panics(
        t in prop::collection::vec(prop_oneof![any::<f64>(), -10.0..10.0f64], 0..40),
        y in prop::collection::vec(prop_oneof![any::<f64>(), -10.0..10.0f64], 0..40),
        target in prop_oneof![any::<f64>(), -10.0..10.0f64],
        band in prop_oneof![any::<f64>(), 0.0..1.0f64],
    ) {
        let _ = step(&t, &y, target, band);
        let _ = peak_abs(&t, &y);
    }

    #[test]
    fn figures_of_a_sorted_recording_are_consistent(
        mut t in prop::collection::vec(0.0..10.0f64, 1..60),
        y in prop::collection::vec(-5.0..5.0f64, 60),
        target in -5.0..5.0f64,
        band in 0.001..0.5f64,
    ) {
        t.sort_by(f64::total_cmp);
        let y = &y[..t.len()];
        match step(&t, y, target, band) {
            Err(e) => prop_assert_eq!(e, FigureError::NoStep),
            Ok(f) => {
                let span = t[t.len() - 1] - t[0];
                for v in [f.rise_time, f.settling_time, f.time_to_reach].into_iter().flatten() {
                    prop_assert!((0.0..=span + 1e-9).contains(&v), "{v} outside 0..{span}");
                }
                if let (Some(reach), Some(settle)) = (f.time_to_reach, f.settling_time) {
                    prop_assert!(reach <= settle + 1e-9);
                }
                prop_assert!(f.overshoot_percent >= 0.0);
            }
        }
    }
}
