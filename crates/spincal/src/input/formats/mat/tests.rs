//! The MAT-file reader's tests: written files read back, truncations, located errors, the
//! inflation limit, runs of empty matrices.

use super::reader::*;
use super::*;

/// A little-endian v5 file from (name, class, rows, cols, data type, payload) entries.
/// (name, class, rows, cols, data type, payload).
type Var<'a> = (&'a str, u8, i32, i32, u32, Vec<u8>);

pub(crate) fn write(vars: &[Var], compress: bool) -> Vec<u8> {
    let mut out = Vec::new();
    let mut text = b"MATLAB 5.0 MAT-file, Platform: test, Created on: never".to_vec();
    text.resize(116, b' ');
    out.extend(text);
    out.extend([0u8; 8]);
    out.extend(0x0100u16.to_le_bytes());
    out.extend(b"IM");
    let element = |kind: u32, data: &[u8]| {
        let mut e = Vec::new();
        e.extend(kind.to_le_bytes());
        e.extend((data.len() as u32).to_le_bytes());
        e.extend(data);
        while e.len() % 8 != 0 {
            e.push(0);
        }
        e
    };
    for (name, class, rows, cols, kind, payload) in vars {
        let mut m = Vec::new();
        let mut flags = (*class as u32).to_le_bytes().to_vec();
        flags.extend([0u8; 4]);
        m.extend(element(MI_UINT32, &flags));
        let mut dims = rows.to_le_bytes().to_vec();
        dims.extend(cols.to_le_bytes());
        m.extend(element(MI_INT32, &dims));
        m.extend(element(MI_INT8, name.as_bytes()));
        m.extend(element(*kind, payload));
        let matrix = element(MI_MATRIX, &m);
        if compress {
            use std::io::Write;
            let mut z = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::default());
            z.write_all(&matrix).unwrap();
            let z = z.finish().unwrap();
            out.extend(MI_COMPRESSED.to_le_bytes());
            out.extend((z.len() as u32).to_le_bytes());
            out.extend(z);
        } else {
            out.extend(matrix);
        }
    }
    out
}

fn doubles(v: &[f64]) -> Vec<u8> {
    v.iter().flat_map(|x| x.to_le_bytes()).collect()
}

#[test]
fn reads_vectors_matrices_scalars_in_both_storages() {
    for compress in [false, true] {
        let bytes = write(
            &[
                ("u", 6, 1, 3, MI_DOUBLE, doubles(&[1.0, 2.0, 3.5])),
                ("m", 6, 3, 2, MI_DOUBLE, doubles(&[1.0, 2.0, 3.0, 4.0, 5.0, 6.0])),
                (
                    "k",
                    10,
                    3,
                    1,
                    MI_INT16,
                    [-1i16, 2, 300].iter().flat_map(|x| x.to_le_bytes()).collect(),
                ),
                ("Ts", 6, 1, 1, MI_UINT8, vec![4]),
                ("s", 4, 1, 2, MI_UINT16, vec![104, 0, 105, 0]),
            ],
            compress,
        );
        let mat = parse(&bytes, "f.mat").unwrap();
        let t = table(&mat, "f.mat").unwrap();
        assert_eq!(t.header, ["u", "m_1", "m_2", "k"]);
        assert_eq!(t.columns[0], [1.0, 2.0, 3.5]);
        assert_eq!(t.columns[2], [4.0, 5.0, 6.0]);
        assert_eq!(t.columns[3], [-1.0, 2.0, 300.0]);
        assert_eq!(t.lines, [1, 2, 3]);
        assert!(t.metadata.iter().any(|(_, s)| s == "Ts = 4"), "{:?}", t.metadata);
        assert!(
            t.metadata.iter().any(|(_, s)| s.starts_with("s: 1×2 char")),
            "{:?}",
            t.metadata
        );
    }
}

#[test]
fn every_truncation_is_an_error_or_a_shorter_file_never_a_panic() {
    for compress in [false, true] {
        let bytes = write(&[("u", 6, 1, 3, MI_DOUBLE, doubles(&[1.0, 2.0, 3.5]))], compress);
        for cut in 0..bytes.len() {
            if let Err(e) = parse(&bytes[..cut], "f.mat") {
                assert!(e.to_string().starts_with("f.mat: "), "{e}");
            }
        }
    }
}

#[test]
fn errors_name_the_byte_and_the_variable() {
    let mut bytes = write(&[("volts", 6, 2, 3, MI_DOUBLE, doubles(&[1.0; 5]))], false);
    let e = parse(&bytes, "f.mat").unwrap_err();
    assert_eq!(
        e.to_string(),
        "f.mat: byte 184, variable 'volts': a 2×3 array needs 6 values, the real part holds 5"
    );
    // The element's size claims more than the file holds.
    bytes[132] = 0xff;
    let e = parse(&bytes, "f.mat").unwrap_err();
    assert!(
        e.to_string()
            .starts_with("f.mat: byte 128: the element (type 14) says"),
        "{e}"
    );
    let e = parse(b"MATLAB 5.0 MAT-file", "f.mat").unwrap_err();
    assert!(e.to_string().contains("the header needs 128 bytes"), "{e}");
    let e = parse(b"hello", "f.mat").unwrap_err();
    assert!(matches!(e, MatError::NotMat { .. }));
    // A compressed element that is not zlib.
    let mut z = write(&[("u", 6, 1, 3, MI_DOUBLE, doubles(&[1.0, 2.0, 3.5]))], true);
    z[136] ^= 0xff;
    let e = parse(&z, "f.mat").unwrap_err();
    assert!(
        e.to_string()
            .starts_with("f.mat: byte 128: the compressed element does not inflate"),
        "{e}"
    );
}

fn over(e: MatError) -> (usize, String, u64, u64, u64) {
    match e {
        MatError::OverLimit {
            at,
            what,
            needed,
            limit,
            left,
            ..
        } => (at, what, needed, limit, left),
        other => panic!("expected OverLimit, got {other}"),
    }
}

#[test]
fn a_compressed_element_over_the_limit_is_refused_by_its_tag() {
    let bytes = write(&[("u", 6, 1, 200, MI_DOUBLE, doubles(&[0.0; 200]))], true);
    let e = parse_limited(&bytes, "f.mat", 1000).unwrap_err();
    let text = e.to_string();
    assert!(
        text.starts_with("f.mat: byte 128: the compressed element's first tag states 1664 bytes, over the limit of 1000 bytes"),
        "{text}"
    );
    assert!(text.contains("save -v6"), "{text}");
    assert_eq!(over(e).4, 1000);
    // Within a larger limit it is read.
    assert_eq!(parse_limited(&bytes, "f.mat", 1664).unwrap().variables.len(), 1);
}

#[test]
fn the_limit_holds_for_all_compressed_elements_together() {
    let var = |name| (name, 6u8, 1, 50, MI_DOUBLE, doubles(&[1.0; 50]));
    let bytes = write(&[var("a"), var("b")], true);
    // Each inflates to 464 bytes: the second finds 544 − 464 = 80 left.
    let (at, what, needed, limit, left) = over(parse_limited(&bytes, "f.mat", 544).unwrap_err());
    assert!(at > 128, "{at}");
    assert_eq!((needed, limit, left), (464, 544, 80), "{what}");
    assert_eq!(parse_limited(&bytes, "f.mat", 928).unwrap().variables.len(), 2);
}

#[test]
fn a_stream_longer_than_its_tag_is_refused_while_inflating() {
    use std::io::Write;
    // A tag stating 48 bytes, then 100 000 zeros: the reader stops one byte past the limit.
    let mut inner = Vec::new();
    inner.extend(MI_MATRIX.to_le_bytes());
    inner.extend(48u32.to_le_bytes());
    let mut z = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::default());
    z.write_all(&inner).unwrap();
    z.write_all(&vec![0u8; 100_000]).unwrap();
    let z = z.finish().unwrap();
    let mut bytes = write(&[], false);
    bytes.extend(MI_COMPRESSED.to_le_bytes());
    bytes.extend((z.len() as u32).to_le_bytes());
    bytes.extend(z);
    let (at, what, needed, limit, _) = over(parse_limited(&bytes, "f.mat", 4096).unwrap_err());
    assert_eq!((at, needed, limit), (128, 4097, 4096), "{what}");
}

#[test]
fn values_from_compressed_elements_are_counted_before_they_are_allocated() {
    // 2 000 uint8 values inflate to about 2 kB but take 16 kB as f64.
    let bytes = write(&[("u", 9, 1, 2000, MI_UINT8, vec![7u8; 2000])], true);
    let (at, what, needed, _, left) = over(parse_limited(&bytes, "f.mat", 10_000).unwrap_err());
    assert_eq!((at, needed, left), (128, 16_000, 10_000));
    assert_eq!(what, "the values of variable 'u' (1×2000) as f64 take");
    // Uncompressed, the file holds them: no limit.
    let plain = write(&[("u", 9, 1, 2000, MI_UINT8, vec![7u8; 2000])], false);
    assert_eq!(
        parse_limited(&plain, "f.mat", 10).unwrap().variables[0]
            .values
            .len(),
        2000
    );
}

#[test]
fn a_run_of_empty_matrix_elements_is_one_entry() {
    let mut bytes = write(&[("u", 6, 1, 3, MI_DOUBLE, doubles(&[1.0, 2.0, 3.0]))], false);
    for _ in 0..1000 {
        bytes.extend(MI_MATRIX.to_le_bytes());
        bytes.extend(0u32.to_le_bytes());
    }
    let mat = parse(&bytes, "f.mat").unwrap();
    assert_eq!(mat.skipped.len(), 1);
    assert_eq!(
        mat.skipped[0].why,
        format!(
            "1000 empty matrix elements, the first at byte {}",
            bytes.len() - 8000
        )
    );
}
