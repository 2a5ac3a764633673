//! The table reader's tests: values, separators, headers and every error against the
//! reference reader, and the windowed and parallel paths against the plain one.

use super::head::WINDOW_BYTES;
use super::mapped::MAP_BYTES;
use super::*;

fn read(text: &str) -> Result<Table, TableError> {
    Table::read(text.as_bytes(), "test.csv", &TableOptions::default())
}

#[test]
fn reads_header_metadata_and_rows() {
    let t = read("Fs,100\nsensor,mpu\nt,ax,ay\n0,1,2\n0.01,1.5,2.5\n").unwrap();
    assert_eq!(t.header, ["t", "ax", "ay"]);
    assert_eq!(
        t.metadata,
        [(1, "Fs,100".to_string()), (2, "sensor,mpu".to_string())]
    );
    assert_eq!(t.columns[1], [1.0, 1.5]);
    assert_eq!(t.lines, [4, 5]);
    assert_eq!(t.delimiter, Delimiter::Comma);
}

#[test]
fn detects_every_separator() {
    for (text, d) in [
        ("1;2;3\n", Delimiter::Semicolon),
        ("1\t2\t3\n", Delimiter::Tab),
        ("1  2 3\n", Delimiter::Whitespace),
        ("1,2,3,\n", Delimiter::Comma),
    ] {
        let t = read(text).unwrap();
        assert_eq!(t.delimiter, d, "{text:?}");
        assert_eq!(t.n_columns(), 3, "{text:?}");
    }
}

#[test]
fn errors_name_line_and_column() {
    let e = read("t,ax\n0,1\n0.01,abc\n").unwrap_err();
    assert_eq!(e.to_string(), "test.csv:3, column 2 (ax): 'abc' is not a number");
    let e = read("t,ax\n0,1\n0.01,NaN\n").unwrap_err();
    assert_eq!(
        e.to_string(),
        "test.csv:3, column 2 (ax): the value is NaN; spincal needs finite numbers"
    );
    let e = read("t,ax\n0,1\n0.01,\n0.02,1\n").unwrap_err();
    assert_eq!(e.to_string(), "test.csv:3, column 2 (ax): the cell is empty");
    let e = read("t,ax\n0,1\n0.01,1,3\n").unwrap_err();
    assert_eq!(e.to_string(), "test.csv:3: expected 2 fields, found 3");
    let e = read("t,ax,ay\n0,1,2\n0.01,1").unwrap_err();
    assert_eq!(
        e.to_string(),
        "test.csv: the last line (3) has no line ending and only 2 of 3 fields: the file looks truncated"
    );
    assert_eq!(read("").unwrap_err().to_string(), "test.csv: the file is empty");
    assert_eq!(
        read("t,ax\n").unwrap_err().to_string(),
        "test.csv: no numeric data rows found (1 lines read, none was all numbers)"
    );
}

#[test]
fn reads_a_text_label_column() {
    let t = read_labelled(
        "# note\npart,n,ax\nx_p,0,1.5\nx_a,1,-2\n".as_bytes(),
        "l.csv",
        &TableOptions::default(),
        "PART",
    )
    .unwrap();
    assert_eq!(t.labels, ["x_p", "x_a"]);
    assert_eq!(t.table.header, ["n", "ax"]);
    assert_eq!(t.table.columns[1], [1.5, -2.0]);
    let e = read_labelled(
        "part,n,ax\nx,0,q\n".as_bytes(),
        "l.csv",
        &TableOptions::default(),
        "part",
    )
    .unwrap_err();
    assert_eq!(e.to_string(), "l.csv:2, column 3 (ax): 'q' is not a number");
    let e = read_labelled(
        "n,ax\n0,1\n".as_bytes(),
        "l.csv",
        &TableOptions::default(),
        "part",
    )
    .unwrap_err();
    assert!(e.to_string().contains("label column 'part'"), "{e}");
}

#[test]
fn columns_by_name_or_one_based_index() {
    let t = read("time,AX\n0,1\n").unwrap();
    assert_eq!(t.column_index("ax"), Some(1));
    assert_eq!(t.column_index("1"), Some(0));
    assert_eq!(t.column_index("3"), None);
}

/// What a reader made of some input, comparable across readers: the table's every bit, or the
/// error's text.
fn outcome(result: Result<Table, TableError>) -> Result<String, String> {
    result
        .map(|t| {
            let bits: Vec<Vec<u64>> = t
                .columns
                .iter()
                .map(|c| c.iter().map(|v| v.to_bits()).collect())
                .collect();
            format!(
                "{} {:?} {:?} {:?} {:?} {:?}",
                t.file, t.delimiter, t.header, t.metadata, bits, t.lines
            )
        })
        .map_err(|e| e.to_string())
}

/// Every row the streaming reader gives (`next_record`), as text.
fn streamed(bytes: &[u8], options: &TableOptions) -> Result<Vec<String>, String> {
    let mut rows = RowReader::new(bytes, "test.csv", options).map_err(|e| e.to_string())?;
    let mut values = Vec::new();
    let mut out = Vec::new();
    while let Some(record) = rows.next_record(&mut values).map_err(|e| e.to_string())? {
        out.push(match record {
            Record::Parsed { line } => {
                format!(
                    "{line} {:?}",
                    values.iter().map(|v| v.to_bits()).collect::<Vec<_>>()
                )
            }
            Record::Refused { line, text, error } => format!("{line} refused {text:?}: {error}"),
            Record::Incomplete { line, column, .. } => format!("{line} incomplete at column {column}"),
        });
    }
    Ok(out)
}

fn old_streamed(bytes: &[u8], options: &TableOptions) -> Result<Vec<String>, String> {
    let mut rows = reference::OldRowReader::new(bytes, "test.csv", options).map_err(|e| e.to_string())?;
    let mut values = Vec::new();
    let mut out = Vec::new();
    while let Some(record) = rows.next_record(&mut values).map_err(|e| e.to_string())? {
        out.push(match record {
            Record::Parsed { line } => {
                format!(
                    "{line} {:?}",
                    values.iter().map(|v| v.to_bits()).collect::<Vec<_>>()
                )
            }
            Record::Refused { line, text, error } => format!("{line} refused {text:?}: {error}"),
            Record::Incomplete { line, column, .. } => format!("{line} incomplete at column {column}"),
        });
    }
    Ok(out)
}

/// The byte-level reader, in any number of chunks, and the streaming reader agree with the
/// line-at-a-time reader they replace: same bits, same lines, same errors.
fn agree_with(bytes: &[u8], options: &TableOptions) {
    let old = outcome(reference::read(bytes, "test.csv", options));
    assert_eq!(
        outcome(Table::parse(bytes, "test.csv", options)),
        old,
        "{:?}",
        String::from_utf8_lossy(bytes)
    );
    let windows = [
        (2, WINDOW_BYTES),
        (3, WINDOW_BYTES),
        (7, WINDOW_BYTES),
        (64, WINDOW_BYTES),
        (1, 1),
        (1, 9),
        (3, 1),
        (5, 40),
    ];
    for (chunks, window) in windows {
        let chunked = TableHead::new(bytes, "test.csv", options).and_then(|head| {
            let every: Vec<(usize, f64)> = (0..head.width()).map(|c| (c, 1.0)).collect();
            let rows = head.rows_in_windows(&every, |_| chunks, window)?;
            Ok(Table {
                file: "test.csv".into(),
                delimiter: head.delimiter,
                header: head.header,
                metadata: head.metadata,
                columns: rows.columns,
                lines: rows.lines,
            })
        });
        assert_eq!(
            outcome(chunked),
            old,
            "{chunks} chunks, windows of {window} bytes: {:?}",
            String::from_utf8_lossy(bytes)
        );
    }
    // The streaming reader stops at the first error with `next_row` …
    let mut next_row = RowReader::new(bytes, "test.csv", options).and_then(|mut rows| {
        let mut columns = vec![Vec::new(); rows.width()];
        let mut lines = Vec::new();
        let mut values = Vec::new();
        while let Some(line) = rows.next_row(&mut values)? {
            columns.iter_mut().zip(&values).for_each(|(c, v)| c.push(*v));
            lines.push(line);
        }
        Ok(Table {
            file: "test.csv".into(),
            delimiter: rows.delimiter,
            header: rows.header.clone(),
            metadata: rows.metadata.clone(),
            columns,
            lines,
        })
    });
    if let Ok(t) = &mut next_row {
        t.file = "test.csv".into();
    }
    assert_eq!(
        outcome(next_row),
        old,
        "next_row: {:?}",
        String::from_utf8_lossy(bytes)
    );
    // … and goes on past it with `next_record`. The old reader refused a bad first data row
    // while looking for the header; the new one reads ahead as text and refuses that row
    // like any other, with the same message.
    let new = streamed(bytes, options);
    match (&new, old_streamed(bytes, options)) {
        (Ok(rows), Err(old)) if rows.first().is_some_and(|r| r.ends_with(&format!(": {old}"))) => {}
        (new, old) => assert_eq!(new, &old, "{:?}", String::from_utf8_lossy(bytes)),
    }
}

fn agree(bytes: &[u8]) {
    agree_with(bytes, &TableOptions::default());
}

#[test]
fn fast_reader_agrees_on_awkward_files() {
    for text in [
        // line endings, BOM, blank and comment lines, an empty last line
        &b"t,ax\r\n0,1\r\n0.01,2\r\n"[..],
        b"\xef\xbb\xbft,ax\n0,1\n0.01,2\n",
        b"\xef\xbb\xbf0,1\n0.01,2",
        b"t,ax\n\n0,1\n   \n# note\n  % note\n0.01,2\n\n",
        b"t,ax\n0,1\n0.01,2\n\n\n",
        b"t,ax\n0,1\n0.01,2\n   ",
        b"t,ax\n0,1\n0.01,2\r\r\n",
        b"t,ax\n0,1\n0.01,2\r",
        // quoted header names, trailing separators, padding
        b"\"t\",\"ax\"\n0,1\n0.01,2\n",
        b"t,ax,\n0,1,\n0.01 , 2 ,\t\n",
        b"t,ax\n0,1\n0.01,2,,\n",
        b"t,ax\n 0 ,\t1\x0b\n0.01,\x0c2\n",
        // every separator
        b"t;ax;ay\n0;1;2\n1;2;3;\n",
        b"t\tax\tay\n0\t1\t2\n1\t\t3\n",
        b"t\tax\n0\t1\n\t1\t2\n",
        b"t\tax\n0\t1\n1 \t 2\t\n",
        b"t ax ay\n0 1 2\n  1\t2   3  \n",
        b"0 1 2\n1 2\n",
        b"0 1 2\n1 2 3 4\n",
        b"0 1 2\n1,2 3 4\n",
        // number syntax
        b"t,ax\n0,+1\n1,-.5\n2,5.\n3,1e5\n4,1E-5\n5,-0\n6,00012\n7,1e+300\n",
        b"t,ax\n0,1\n1,1e\n",
        b"t,ax\n0,1\n1,.\n",
        b"t,ax\n0,1\n1,1.2.3\n",
        b"t,ax\n0,1\n1,0x10\n",
        b"t,ax\n0,1\n1,1_0\n",
        b"t,ax\n0,1\n1,1e400\n",
        b"t,ax\n0,1\n1,1e-400\n",
        b"t,ax\n0,1\n1,-inf\n",
        b"t,ax\n0,1\n1,infinity\n",
        b"t,ax\n0,1\n1,nan\n",
        b"t,ax\n0,NaN\n",
        b"t,ax\n0,1\n1,123456789012345678901234567890.123456789e-10\n",
        b"t,ax\n0,1\n1,0.30000000000000004441\n2,2.2250738585072011e-308\n3,1.7976931348623157e308\n",
        b"t,ax\n0,1\n1,9007199254740993\n2,0.1000000000000000055511151231257827\n",
        // errors
        b"t,ax\n0,1\n1,\"2\"\n",
        b"t,ax\n0,1\n1,2 3\n",
        b"t,ax\n0,1\n1\n",
        b"t,ax,ay\n0,1,2\n1,2",
        b"t,ax,ay\n0,1,2\n1,2,",
        b"t,ax\n0,1\n1,abc\n2,3",
        // Unicode spacing and text
        "t,ax\n0,1\n1,\u{a0}2\n".as_bytes(),
        "t,ax\n0,1\n\u{3000}# note\n1,2\n".as_bytes(),
        "t ax\n0 1\n1\u{2003}2\n".as_bytes(),
        "t,ax\n0,1\n1,2µ\n".as_bytes(),
        "t,ax\n0,1\n# µ\n1,2\n".as_bytes(),
        // not UTF-8: in a row, in a comment, after an earlier error, at the very start
        b"t,ax\n0,1\n1,2\n2,\xff\n3,4\n",
        b"t,ax\n0,1\n# \xff\n3,4\n",
        b"t,ax\n0,1\n1,x\n2,\xff\n",
        b"t,ax\n0,1\n1,2\n2,3\xff",
        b"\xff\n0,1\n",
        b"t,ax\n\xff\n0,1\n",
        // no data
        b"",
        b"\n\n",
        b"t,ax\n",
        b"t,ax\n# only\n",
    ] {
        agree(text);
    }
    for delimiter in [
        Delimiter::Comma,
        Delimiter::Semicolon,
        Delimiter::Tab,
        Delimiter::Whitespace,
    ] {
        let options = TableOptions {
            delimiter: Some(delimiter),
        };
        for text in [
            &b"t,ax\n0,1\n1,2\n"[..],
            b"t;ax\n0;1\n1;2;\n",
            b"t\tax\n0\t1\n1\t2\n",
            b"t ax\n0 1\n1  2\n",
            b"0,1 2\n1,2 3\n",
        ] {
            agree_with(text, &options);
        }
    }
}

#[test]
fn fast_reader_agrees_on_random_text() {
    use proptest::prelude::*;
    let token = prop_oneof![
        (-1e6f64..1e6).prop_map(|v| format!("{v}")),
        (-1e6f64..1e6).prop_map(|v| format!("{v:e}")),
        any::<f64>().prop_map(|v| format!("{v}")),
        any::<u64>().prop_map(|v| format!("{v}.{}", v % 1000)),
        Just("NaN".to_string()),
        Just("inf".to_string()),
        Just("".to_string()),
        Just("x".to_string()),
        Just("1e".to_string()),
        Just("\"t\"".to_string()),
        Just("\u{a0}".to_string()),
        Just("é".to_string()),
    ];
    let sep = prop_oneof![
        4 => Just(","),
        1 => Just(";"),
        1 => Just("\t"),
        1 => Just(" "),
        1 => Just("  "),
        3 => Just("\n"),
        1 => Just("\r\n"),
        1 => Just("\n# c\n"),
        1 => Just("\n\n"),
    ];
    let text = proptest::collection::vec((token, sep), 0..80).prop_map(|v| {
        let body: String = v.into_iter().map(|(t, s)| t + s).collect();
        format!("t,ax,ay\n0,1,2\n{body}")
    });
    let mut runner = proptest::test_runner::TestRunner::new(proptest::test_runner::Config {
        cases: 2000,
        ..Default::default()
    });
    runner
        .run(&text, |text| {
            agree(text.as_bytes());
            Ok(())
        })
        .unwrap();
}

/// A file of `rows` rows of full-precision numbers, as spincal writes them.
fn long_file(rows: usize) -> String {
    let mut text = String::from("t,ax,ay\n");
    for i in 0..rows {
        let x = (i as f64 * 0.7).sin() * 9.81;
        text.push_str(&format!("{},{},{}\n", i as f64 * 0.01, x, x / 3.0));
    }
    text
}

#[test]
fn bad_number_in_a_later_chunk_names_its_line() {
    let mut lines: Vec<String> = long_file(20_000).lines().map(String::from).collect();
    lines[15_000 - 1] = "150,1,x".into();
    let text = lines.join("\n") + "\n";
    let head = TableHead::new(text.as_bytes(), "test.csv", &TableOptions::default()).unwrap();
    for chunks in [1, 2, 8, 100] {
        let e = head.rows_in_chunks(&[(0, 1.0), (2, 1.0)], chunks).unwrap_err();
        assert_eq!(
            e.to_string(),
            "test.csv:15000, column 3 (ay): 'x' is not a number"
        );
        // Text in a column not chosen is no error.
        assert_eq!(
            head.rows_in_chunks(&[(0, 1.0)], chunks).unwrap().lines.len(),
            20_000
        );
    }
    // The first fault in the file wins, even when a later chunk has one too.
    lines[3_000 - 1] = "30,,1".into();
    let text = lines.join("\n") + "\n";
    let head = TableHead::new(text.as_bytes(), "test.csv", &TableOptions::default()).unwrap();
    for chunks in [1, 2, 8, 100] {
        let e = head.rows_in_chunks(&[(1, 1.0)], chunks).unwrap_err();
        assert_eq!(e.to_string(), "test.csv:3000, column 2 (ax): the cell is empty");
    }
    agree(text.as_bytes());
}

/// An empty cell is an error only in a chosen column, in any chunk; elsewhere the row is kept.
#[test]
fn empty_cells_in_columns_not_chosen_are_allowed() {
    let mut lines: Vec<String> = long_file(20_000).lines().map(String::from).collect();
    lines[3_000 - 1] = "30,,1".into();
    lines[17_000 - 1] = "170,2,".into();
    let text = lines.join("\n") + "\n";
    let head = TableHead::new(text.as_bytes(), "test.csv", &TableOptions::default()).unwrap();
    for chunks in [1, 2, 8, 100] {
        let rows = head.rows_in_chunks(&[(0, 1.0)], chunks).unwrap();
        assert_eq!(rows.lines.len(), 20_000);
        assert_eq!(rows.columns[0][3_000 - 2], 30.0);
        let e = head.rows_in_chunks(&[(0, 1.0), (2, 1.0)], chunks).unwrap_err();
        assert_eq!(e.to_string(), "test.csv:17000, column 3 (ay): the cell is empty");
    }
    let t = Table::parse_columns(text.as_bytes(), "test.csv", &TableOptions::default(), &["t"]).unwrap();
    assert_eq!(
        (t.header.as_slice(), t.n_rows()),
        (&["t".to_string()][..], 20_000)
    );
    let e = Table::parse(text.as_bytes(), "test.csv", &TableOptions::default()).unwrap_err();
    assert_eq!(e.to_string(), "test.csv:3000, column 2 (ax): the cell is empty");
    let e = Table::parse_columns(text.as_bytes(), "test.csv", &TableOptions::default(), &["q"]).unwrap_err();
    assert_eq!(e.to_string(), "test.csv: no column 'q' (columns: t, ax, ay)");
}

#[test]
fn chunks_and_threads_do_not_change_a_bit() {
    let text = long_file(150_000) + "# end\n\n";
    let head = TableHead::new(text.as_bytes(), "test.csv", &TableOptions::default()).unwrap();
    let targets = [(2, 1.0), (0, 1e-3), (1, std::f64::consts::PI / 180.0), (1, 1.0)];
    let one = head.rows_in_chunks(&targets, 1).unwrap();
    assert_eq!(one.lines.len(), 150_000);
    assert_eq!(one.lines[149_999], 150_001);
    for chunks in [2, 5, 16] {
        assert_eq!(head.rows_in_chunks(&targets, chunks).unwrap(), one);
        for window in [1 << 12, 100_001] {
            assert_eq!(head.rows_in_windows(&targets, |_| chunks, window).unwrap(), one);
        }
    }
    for threads in [1, 2, 4] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        assert_eq!(pool.install(|| head.rows(&targets)).unwrap(), one);
    }
    agree(text.as_bytes());
}

/// A mapped file read in small windows gives back each window's pages as it goes: the rows are
/// those of the same bytes in a `Vec`, and the map still reads as the file afterwards.
#[test]
fn a_mapped_file_read_in_windows_is_read_whole_and_left_intact() {
    let text = long_file(40_000) + "# end\n";
    assert!(
        text.len() as u64 >= MAP_BYTES,
        "{} bytes are too few to be mapped",
        text.len()
    );
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("long.csv");
    std::fs::write(&path, &text).unwrap();
    let bytes = read_file(&path).unwrap();
    assert!(matches!(bytes, FileBytes::Mapped(_)));
    let targets = [(0, 1.0), (2, 2.0)];
    let mapped = TableHead::new(&bytes, "long.csv", &TableOptions::default()).unwrap();
    let copied = TableHead::new(text.as_bytes(), "long.csv", &TableOptions::default()).unwrap();
    let expected = copied.rows(&targets).unwrap();
    for chunks in [1, 3] {
        assert_eq!(
            mapped.rows_in_windows(&targets, |_| chunks, 5000).unwrap(),
            expected
        );
    }
    assert!(*bytes == *text.as_bytes());
}
