//! The MAT-file reader on any bytes: never panics. The first byte chooses how the rest is used:
//! as a whole file, after a valid 128-byte header (either byte order), or zlib-compressed into one
//! `miCOMPRESSED` element after that header, so the element parser is reached through both paths.
//! What parses has `rows × cols` values per variable; its table has equal columns, one line per
//! row, and every error message starts with the file name.
#![no_main]

use std::io::Write;

use libfuzzer_sys::fuzz_target;
use spincal::input::formats::{mat, read_bytes, Format, ReadOptions};

fn header(big_endian: bool) -> Vec<u8> {
    let mut h = b"MATLAB 5.0 MAT-file, Platform: fuzz, Created on: never".to_vec();
    h.resize(124, b' ');
    if big_endian {
        h.extend(0x0100u16.to_be_bytes());
        h.extend(b"MI");
    } else {
        h.extend(0x0100u16.to_le_bytes());
        h.extend(b"IM");
    }
    h
}

fuzz_target!(|data: &[u8]| {
    let Some((&mode, rest)) = data.split_first() else {
        return;
    };
    let big_endian = mode & 4 != 0;
    let file = match mode & 3 {
        0 => rest.to_vec(),
        1 => [header(big_endian), rest.to_vec()].concat(),
        _ => {
            let mut z = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::fast());
            z.write_all(rest).unwrap();
            let z = z.finish().unwrap();
            let mut f = header(big_endian);
            let word = |v: u32| {
                if big_endian {
                    v.to_be_bytes()
                } else {
                    v.to_le_bytes()
                }
            };
            f.extend(word(15));
            f.extend(word(z.len() as u32));
            f.extend(z);
            f
        }
    };
    match mat::parse(&file, "fuzz.mat") {
        Ok(parsed) => {
            for v in &parsed.variables {
                assert_eq!(v.values.len(), v.rows * v.cols);
                assert!(v.values.iter().all(|x| x.is_finite()));
            }
            match mat::table(&parsed, "fuzz.mat") {
                Ok(t) => {
                    assert_eq!(t.header.len(), t.columns.len());
                    assert!(!t.columns.is_empty());
                    for c in &t.columns {
                        assert_eq!(c.len(), t.lines.len());
                    }
                }
                Err(e) => assert!(e.to_string().starts_with("fuzz.mat: "), "{e}"),
            }
        }
        Err(e) => assert!(e.to_string().starts_with("fuzz.mat: "), "{e}"),
    }
    let options = ReadOptions {
        format: Some(Format::Mat),
        ..Default::default()
    };
    if let Err(e) = read_bytes(&file, "fuzz.mat", &options) {
        let _ = e.to_string();
    }
});
