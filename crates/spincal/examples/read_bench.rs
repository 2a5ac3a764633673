//! Reading-speed benchmark for bench/io/run.sh.
//!
//! `read_bench gen DIR ROWS` writes DIR/bench.csv (t,ax,ay,az,gx,gy,gz) and DIR/bench.gx1 (the same
//! samples as a 3DM-GX1 0x03 stream); `read_bench read DIR REPEATS [csv]` times spincal's CSV reader
//! and (without `csv`) its streaming `RowReader` and the GX1 decoder, file read included, and prints
//! `name best_seconds median_seconds cpu_seconds megabytes samples`.

use std::io::BufReader;
use std::path::Path;
use std::time::Instant;

use rand::{Rng, SeedableRng};
use spincal::input::formats::gx1::{decode, encode, Gx1EncodeOptions, Gx1Options};
use spincal::input::formats::{read_path, Format, ReadOptions};
use spincal::input::recording::{AccelUnit, Recording, Source};
use spincal::input::table::{Record, RowReader, TableOptions};

fn generate(dir: &Path, rows: usize) {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
    let time_s: Vec<f64> = (0..rows).map(|i| i as f64 * 0.01).collect();
    let mut axis = |k: f64| -> Vec<f64> { (0..rows).map(|_| k + rng.gen_range(-2.0..2.0)).collect() };
    let rec = Recording {
        accel_mps2: [axis(0.0), axis(0.0), axis(9.8)],
        gyro_radps: Some([axis(0.0), axis(0.0), axis(0.0)]),
        temperature_c: None,
        time_s,
        source: Source::default(),
    };
    std::fs::create_dir_all(dir).expect("create bench dir");
    rec.write_csv_path(&dir.join("bench.csv"), AccelUnit::Mps2)
        .expect("write csv");
    let bytes = encode(&rec, &Gx1EncodeOptions::default()).expect("encode");
    std::fs::write(dir.join("bench.gx1"), bytes).expect("write gx1");
}

/// Seconds this process has run on a CPU (Linux's /proc/self/schedstat; 0 elsewhere). Under load
/// it is steadier than the wall clock, and peers.py reads the same counter.
fn cpu_seconds() -> f64 {
    std::fs::read_to_string("/proc/self/schedstat")
        .ok()
        .and_then(|s| s.split_whitespace().next()?.parse::<f64>().ok())
        .map_or(0.0, |ns| ns * 1e-9)
}

/// Best and median wall seconds of `repeats` runs, the least on-CPU seconds, and the last result.
fn timed<T>(repeats: usize, mut f: impl FnMut() -> T) -> (f64, f64, f64, T) {
    let mut secs = Vec::new();
    let mut cpu = f64::INFINITY;
    let mut out = None;
    for _ in 0..repeats.max(1) {
        let (start, cpu_start) = (Instant::now(), cpu_seconds());
        let v = f();
        secs.push(start.elapsed().as_secs_f64());
        cpu = cpu.min(cpu_seconds() - cpu_start);
        out = Some(v);
    }
    secs.sort_by(f64::total_cmp);
    (
        secs[0],
        secs[secs.len() / 2],
        cpu,
        out.expect("at least one repeat"),
    )
}

fn read(dir: &Path, repeats: usize, csv_only: bool) {
    let csv = dir.join("bench.csv");
    let mb = std::fs::metadata(&csv).expect("csv exists").len() as f64 / 1e6;
    let options = ReadOptions {
        format: Some(Format::Csv),
        ..Default::default()
    };
    let (best, median, cpu, loaded) = timed(repeats, || read_path(&csv, &options).expect("read csv"));
    println!(
        "spincal-csv {best:.6} {median:.6} {cpu:.6} {mb:.3} {}",
        loaded.recording.len()
    );
    if csv_only {
        return;
    }
    // The streaming reader `spincal correct` uses: one row at a time, constant memory.
    let (best, median, cpu, rows) = timed(repeats, || {
        let file = std::fs::File::open(&csv).expect("open csv");
        let mut rows =
            RowReader::new(BufReader::new(file), "bench.csv", &TableOptions::default()).expect("header");
        let (mut values, mut n) = (Vec::new(), 0);
        while let Some(record) = rows.next_record(&mut values).expect("read") {
            n += usize::from(matches!(record, Record::Parsed { .. }));
        }
        n
    });
    println!("spincal-csv-stream {best:.6} {median:.6} {cpu:.6} {mb:.3} {rows}");
    let gx1 = dir.join("bench.gx1");
    let (best, median, cpu, (rec, _)) = timed(repeats, || {
        let bytes = std::fs::read(&gx1).expect("read gx1");
        decode(&bytes, "bench.gx1", &Gx1Options::default()).expect("decode")
    });
    let mb = std::fs::metadata(&gx1).expect("gx1 exists").len() as f64 / 1e6;
    println!("spincal-gx1 {best:.6} {median:.6} {cpu:.6} {mb:.3} {}", rec.len());
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let usage = "usage: read_bench gen DIR ROWS | read_bench read DIR REPEATS [csv]";
    match (args.get(1).map(String::as_str), args.get(2), args.get(3)) {
        (Some("gen"), Some(dir), Some(n)) => generate(Path::new(dir), n.parse().expect(usage)),
        (Some("read"), Some(dir), Some(r)) => read(
            Path::new(dir),
            r.parse().expect(usage),
            args.get(4).is_some_and(|a| a == "csv"),
        ),
        _ => {
            eprintln!("{usage}");
            std::process::exit(2);
        }
    }
}
