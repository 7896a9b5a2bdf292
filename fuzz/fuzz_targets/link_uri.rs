//! `--link` URIs. Invariants: no panic; every accepted URI prints to a URI
//! that parses to the same link.
#![no_main]

use axisctl::link::{LinkSpec, SerialFormat};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else { return };
    if let Ok(spec) = text.parse::<LinkSpec>() {
        let printed = spec.to_string();
        assert_eq!(printed.parse::<LinkSpec>(), Ok(spec.clone()), "{text:?} printed as {printed:?}");
        let _ = spec.is_can();
    }
    if let Ok(f) = text.parse::<SerialFormat>() {
        assert_eq!(f.to_string().parse::<SerialFormat>(), Ok(f));
        assert!((7..=8).contains(&f.data_bits()));
    }
});
