//! Bounded memory on hostile and large inputs (issue 31, item 4): a MAT-file zlib bomb is refused
//! in under 100 MB, and `inspect` on a delimited text file holds as much for 80 MB as for 20 MB.
//! Each case checks the exit code, the message, the input's checksum, and the child's peak
//! resident memory (its own `ru_maxrss`, from `wait4` on its pid: no other test's child counts).

use std::io::{Read, Write};
use std::path::Path;
use std::process::{Command, Stdio};

/// A file's length and CRC-32.
fn checksum(path: &Path) -> (u64, u32) {
    let mut f = std::fs::File::open(path).unwrap();
    let (mut hasher, mut buf, mut len) = (crc32fast::Hasher::new(), vec![0u8; 1 << 20], 0u64);
    loop {
        let n = f.read(&mut buf).unwrap();
        if n == 0 {
            return (len, hasher.finalize());
        }
        hasher.update(&buf[..n]);
        len += n as u64;
    }
}

/// Runs spincal with `args`: exit code, stdout, stderr and peak resident memory in MB.
#[cfg(target_os = "linux")]
// The child is reaped by `wait4` below, which gives its own peak memory; `Child::wait` cannot.
#[allow(clippy::zombie_processes)]
fn run_measured(args: &[&std::ffi::OsStr]) -> (i32, String, String, f64) {
    let mut child = Command::new(assert_cmd::cargo::cargo_bin("spincal"))
        .args(args)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let (mut out, mut err) = (String::new(), String::new());
    let stderr = child.stderr.take().unwrap();
    let reader = std::thread::spawn(move || {
        let mut s = String::new();
        std::io::BufReader::new(stderr).read_to_string(&mut s).unwrap();
        s
    });
    child.stdout.take().unwrap().read_to_string(&mut out).unwrap();
    err.push_str(&reader.join().unwrap());
    let mut status = 0;
    // SAFETY: a plain wait4 on our own child's pid, into locals; the child is not waited for
    // elsewhere (`child` is dropped without `wait`).
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    let pid = unsafe { libc::wait4(child.id() as libc::pid_t, &mut status, 0, &mut usage) };
    assert_eq!(pid, child.id() as libc::pid_t, "wait4 failed");
    assert!(libc::WIFEXITED(status), "spincal ended by a signal: {status}");
    let code = libc::WEXITSTATUS(status);
    (code, out, err, usage.ru_maxrss as f64 / 1024.0)
}

fn os(s: &str) -> &std::ffi::OsStr {
    std::ffi::OsStr::new(s)
}

/// A little-endian v5 MAT-file header.
fn mat_header() -> Vec<u8> {
    let mut out = b"MATLAB 5.0 MAT-file, Platform: GLNXA64, Created on: test".to_vec();
    out.resize(116, b' ');
    out.extend([0u8; 8]);
    out.extend(0x0100u16.to_le_bytes());
    out.extend(b"IM");
    out
}

/// A MAT-file whose one compressed element inflates to `zeros` zero bytes after `inner` (the
/// start of what it holds), written without holding them: the bomb.
fn mat_bomb(path: &Path, inner: &[u8], zeros: u64) {
    let mut z = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::default());
    z.write_all(inner).unwrap();
    let block = vec![0u8; 1 << 20];
    let mut left = zeros;
    while left > 0 {
        let n = left.min(block.len() as u64) as usize;
        z.write_all(&block[..n]).unwrap();
        left -= n as u64;
    }
    let z = z.finish().unwrap();
    let mut bytes = mat_header();
    bytes.extend(15u32.to_le_bytes());
    bytes.extend((z.len() as u32).to_le_bytes());
    bytes.extend(z);
    std::fs::write(path, bytes).unwrap();
}

/// The start of a `miMATRIX` element: a `rows × cols` double array named `z` of zeros.
fn zeros_matrix_head(rows: u32, cols: u32) -> Vec<u8> {
    let values = rows as u64 * cols as u64 * 8;
    let mut m = Vec::new();
    let mut element = |kind: u32, data: &[u8]| {
        m.extend(kind.to_le_bytes());
        m.extend((data.len() as u32).to_le_bytes());
        m.extend(data);
        while m.len() % 8 != 0 {
            m.push(0);
        }
    };
    element(6, &[6, 0, 0, 0, 0, 0, 0, 0]);
    let mut dims = rows.to_le_bytes().to_vec();
    dims.extend(cols.to_le_bytes());
    element(5, &dims);
    element(1, b"z");
    let mut head = Vec::new();
    head.extend(14u32.to_le_bytes());
    head.extend(((m.len() as u64 + 8 + values) as u32).to_le_bytes());
    head.extend(m);
    head.extend(9u32.to_le_bytes());
    head.extend((values as u32).to_le_bytes());
    head
}

#[cfg(target_os = "linux")]
#[test]
fn a_mat_zlib_bomb_is_refused_in_under_100_mb() {
    let dir = tempfile::tempdir().unwrap();
    // 30 M × 4 zeros (960 MB inflated) in under 1 MB.
    let bomb = dir.path().join("bomb.mat");
    mat_bomb(&bomb, &zeros_matrix_head(30_000_000, 4), 30_000_000 * 4 * 8);
    let before = checksum(&bomb);
    assert!(before.0 < 1_100_000, "{before:?}");
    let (code, _, err, peak_mb) = run_measured(&[os("inspect"), bomb.as_os_str()]);
    assert_eq!(code, 1, "{err}");
    assert!(
        err.contains(&format!(
            "{}: byte 128: the compressed element's first tag states 960000064 bytes, over the limit of 67108864 bytes",
            bomb.display()
        )),
        "{err}"
    );
    assert!(err.contains("save -v6"), "{err}");
    assert!(peak_mb < 100.0, "peak {peak_mb:.1} MB");
    assert_eq!(checksum(&bomb), before);

    // A tag that understates what follows: refused while inflating, one byte past the limit.
    let liar = dir.path().join("liar.mat");
    mat_bomb(&liar, &zeros_matrix_head(1, 1)[..8], 200 << 20);
    let before = checksum(&liar);
    let (code, _, err, peak_mb) = run_measured(&[os("inspect"), liar.as_os_str()]);
    assert_eq!(code, 1, "{err}");
    assert!(
        err.contains("byte 128: the compressed element inflates to at least 67108865 bytes, over the limit of 67108864 bytes"),
        "{err}"
    );
    assert!(peak_mb < 100.0, "peak {peak_mb:.1} MB");
    assert_eq!(checksum(&liar), before);
}

/// A 100 Hz CSV of `rows` rows.
fn write_csv(path: &Path, rows: usize) {
    let mut w = std::io::BufWriter::new(std::fs::File::create(path).unwrap());
    writeln!(w, "t_s,ax_mps2,ay_mps2,az_mps2,temp_c").unwrap();
    for i in 0..rows {
        let x = (i as f64 * 0.001).sin();
        writeln!(
            w,
            "{:.2},{x:.6},{:.6},9.{:06},{:.1}",
            i as f64 * 0.01,
            -x,
            800_000 + i % 1000,
            25.0 + (i % 40) as f64 * 0.1
        )
        .unwrap();
    }
}

#[cfg(target_os = "linux")]
#[test]
fn inspect_memory_does_not_grow_with_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let mut peaks = Vec::new();
    for (rows, name) in [(400_000, "small.csv"), (1_600_000, "large.csv")] {
        let csv = dir.path().join(name);
        write_csv(&csv, rows);
        let before = checksum(&csv);
        let (code, out, err, peak_mb) = run_measured(&[os("inspect"), csv.as_os_str()]);
        assert_eq!(code, 0, "{err}");
        assert!(
            out.contains(&format!(
                "samples: {rows}   duration: {:.3} s   sample rate: 100.0000 Hz",
                (rows - 1) as f64 * 0.01
            )),
            "{out}"
        );
        assert!(out.contains("temperature: 25.00 .. 28.90 °C"), "{out}");
        assert_eq!(checksum(&csv), before);
        peaks.push((before.0 as f64 / 1e6, peak_mb));
    }
    let ((small_mb, small), (large_mb, large)) = (peaks[0], peaks[1]);
    assert!(large_mb > 3.5 * small_mb, "{peaks:?}");
    // Reading it whole held 0.65 × the file: 50 MB more for the larger one.
    assert!(
        large < small + 8.0,
        "peak {small:.1} MB for {small_mb:.0} MB, {large:.1} MB for {large_mb:.0} MB"
    );
}
