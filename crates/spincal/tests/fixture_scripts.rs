//! Peer fixtures still match the scripts that made them: each records the sha256 of its scripts
//! (`scripts_sha256`, written by the script itself), and a script changed without the fixture
//! being regenerated fails here by name.

use std::path::Path;
use std::process::Command;

const REPO: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../..");

/// The fixtures with a peer script behind them (tests/fixtures/flight_stacks: see its README).
const FIXTURES: [&str; 6] = [
    "flight/manifest.json",
    "sysid/arx_lstsq.json",
    "sysid/silverbox_arx.json",
    "sysid/bj_peers.json",
    "ann/pyrenn_peer.json",
    "joint_scipy/fit.json",
];

fn sha256(path: &Path) -> String {
    // coreutils' sha256sum: no hashing crate in the dependency tree for one test.
    let out = Command::new("sha256sum")
        .arg(path)
        .output()
        .unwrap_or_else(|e| panic!("sha256sum (coreutils) is needed: {e}"));
    assert!(out.status.success(), "sha256sum {}: {:?}", path.display(), out);
    String::from_utf8(out.stdout).unwrap()[..64].to_string()
}

#[test]
fn peer_fixtures_record_the_hash_of_the_scripts_that_made_them() {
    let mut stale = Vec::new();
    for name in FIXTURES {
        let path = Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("tests/fixtures")
            .join(name);
        let fixture: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
        let scripts = fixture["scripts_sha256"]
            .as_object()
            .unwrap_or_else(|| panic!("{name} records no scripts_sha256"));
        assert!(!scripts.is_empty(), "{name}: empty scripts_sha256");
        for (script, recorded) in scripts {
            let now = sha256(&Path::new(REPO).join(script));
            if Some(now.as_str()) != recorded.as_str() {
                stale.push(format!("{script} changed since {name} was made (rerun it)"));
            }
        }
    }
    assert!(stale.is_empty(), "{}", stale.join("; "));
}
