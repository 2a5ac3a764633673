//! MCAP reading speed for bench/bags/run.sh.
//!
//! `bag_bench read FILE.mcap REPEATS` times `formats::read_path` on a ROS 2 MCAP file (file read,
//! record walk, CDR decoding, the recording assembled) and prints
//! `spincal-mcap best_seconds median_seconds cpu_seconds megabytes samples checksum`, where the
//! checksum is Σ(ax + ay + az + gx + gy + gz) + Σ t for the peers to match.

use std::path::Path;
use std::time::Instant;

use spincal::input::formats::{read_path, ReadOptions};

/// Seconds this process has run on a CPU (Linux's /proc/self/schedstat; 0 elsewhere).
fn cpu_seconds() -> f64 {
    std::fs::read_to_string("/proc/self/schedstat")
        .ok()
        .and_then(|s| s.split_whitespace().next()?.parse::<f64>().ok())
        .map_or(0.0, |ns| ns * 1e-9)
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    if args.len() != 4 || args[1] != "read" {
        eprintln!("usage: bag_bench read FILE.mcap REPEATS");
        std::process::exit(2);
    }
    let path = Path::new(&args[2]);
    let repeats: usize = args[3].parse().expect("REPEATS");
    let options = ReadOptions::default();
    // Warm-up (page cache), not timed.
    let mut loaded = read_path(path, &options).expect("read bag");
    let mut secs = Vec::new();
    let mut cpu = f64::INFINITY;
    for _ in 0..repeats.max(1) {
        let (start, cpu_start) = (Instant::now(), cpu_seconds());
        loaded = read_path(path, &options).expect("read bag");
        secs.push(start.elapsed().as_secs_f64());
        cpu = cpu.min(cpu_seconds() - cpu_start);
    }
    secs.sort_by(f64::total_cmp);
    let r = &loaded.recording;
    let g = r.gyro_radps.as_ref().expect("gyro");
    let mut checksum = r.time_s.iter().sum::<f64>();
    for (accel, gyro) in r.accel_mps2.iter().zip(g) {
        checksum += accel.iter().sum::<f64>() + gyro.iter().sum::<f64>();
    }
    let mb = std::fs::metadata(path).expect("size").len() as f64 / 1e6;
    println!(
        "spincal-mcap {:.6} {:.6} {:.6} {:.3} {} {:.9e}",
        secs[0],
        secs[secs.len() / 2],
        cpu,
        mb,
        r.len(),
        checksum
    );
}
