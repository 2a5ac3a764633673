//! The campaign file parser on arbitrary text: a campaign or a located error, never a panic; a
//! campaign that parses has at least one recording and every turntable entry's numbers in range.
#![no_main]

use std::path::Path;

use libfuzzer_sys::fuzz_target;
use spincal::campaign::file::{Campaign, EntryKind};

fuzz_target!(|data: &[u8]| {
    let text = String::from_utf8_lossy(data);
    match Campaign::parse(&text, Path::new("fuzz/c.toml")) {
        Ok(c) => {
            assert!(!c.recordings.is_empty());
            for r in &c.recordings {
                assert!(r.line >= 1);
                if let EntryKind::Turntable(t) = &r.kind {
                    assert!(t.rpm > 0.0);
                    if let Some(stated) = t.radius {
                        assert!(stated.tolerance_m > 0.0 && stated.value_m >= 0.0);
                    }
                    assert_ne!(t.out.axis, t.up.axis);
                }
            }
        }
        Err(e) => assert!(e.to_string().starts_with("fuzz/c.toml")),
    }
});
