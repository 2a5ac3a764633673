//! Test data shared by the CLI tests that train correctors.

use std::path::Path;

/// Measured (scaled, offset, squared) and reference sinusoids at 100 Hz, as CSV files.
pub fn write_pair(dir: &Path, n: usize) -> (String, String) {
    let mut measured = String::from("t,ax,ay,az\n");
    let mut reference = String::from("t,ax,ay,az\n");
    for i in 0..n {
        let t = i as f64 / 100.0;
        let w = 2.0 * std::f64::consts::PI * 0.55 * t;
        let (x, y, z) = (
            0.8 * w.sin() + 1.2,
            0.8 * w.cos() + 0.4,
            9.77 + 0.01 * (0.1 * t).sin(),
        );
        let mx = 1.02 * x + 0.05 * y + 0.1 + 0.05 * x * x;
        let my = 0.98 * y - 0.03 * x - 0.2;
        measured += &format!("{t},{mx},{my},{z}\n");
        reference += &format!("{t},{x},{y},{z}\n");
    }
    let m = dir.join("measured.csv");
    let r = dir.join("reference.csv");
    std::fs::write(&m, measured).unwrap();
    std::fs::write(&r, reference).unwrap();
    (m.display().to_string(), r.display().to_string())
}
