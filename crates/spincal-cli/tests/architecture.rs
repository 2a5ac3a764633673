//! The CLI's shape (issue 47 item 6): every command file is parse, one library call, print, in
//! at most 200 code lines; what is neither parsing nor printing lives in the library, where
//! Python reaches it too.

use std::path::Path;

/// The most code lines a command file may hold.
const MAX_CODE_LINES: usize = 200;

/// Lines that are neither blank nor only comment (`//`, `///`, `//!`, and `/* … */` blocks,
/// nested ones included). A comment after code on the same line leaves it a code line; the
/// markers are not looked for inside string literals, which a command file's help text and
/// messages may hold (`"…//…"`), nor after a `//` comment starts.
fn code_lines(text: &str) -> usize {
    let mut depth = 0usize;
    let mut count = 0;
    for line in text.lines() {
        let mut code = false;
        let mut in_string = false;
        let bytes = line.as_bytes();
        let mut i = 0;
        while i < bytes.len() {
            let (c, next) = (bytes[i], bytes.get(i + 1).copied());
            if depth > 0 {
                match (c, next) {
                    (b'*', Some(b'/')) => (depth, i) = (depth - 1, i + 2),
                    (b'/', Some(b'*')) => (depth, i) = (depth + 1, i + 2),
                    _ => i += 1,
                }
                continue;
            }
            if in_string {
                match c {
                    b'\\' => i += 2,
                    b'"' => (in_string, i) = (false, i + 1),
                    _ => i += 1,
                }
                continue;
            }
            match (c, next) {
                (b'/', Some(b'/')) => break,
                (b'/', Some(b'*')) => (depth, i) = (1, i + 2),
                (b'"', _) => (in_string, code, i) = (true, true, i + 1),
                (c, _) if c.is_ascii_whitespace() => i += 1,
                _ => (code, i) = (true, i + 1),
            }
        }
        count += usize::from(code);
    }
    count
}

#[test]
fn the_counter_counts_code_lines_only() {
    let text = "//! A module doc.\n\
                \n\
                /// An item's doc.\n\
                fn f() -> u8 { // a trailing comment\n\
                \x20   /* a block\n\
                \x20      over /* nested */ lines */\n\
                \x20   let s = \"// not a comment\";\n\
                \x20   /* before */ 1\n\
                }\n\
                \t  \n";
    // `fn f`, `let s` and `/* before */ 1` and the closing brace.
    assert_eq!(code_lines(text), 4);
    assert_eq!(code_lines(""), 0);
    assert_eq!(code_lines("let a = \"\\\"\"; // an escaped quote\n// b\n"), 1);
}

#[test]
fn every_command_file_is_at_most_200_code_lines() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("src/commands");
    let mut checked = 0;
    let mut over = Vec::new();
    for entry in std::fs::read_dir(&dir).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_none_or(|e| e != "rs") {
            continue;
        }
        checked += 1;
        let lines = code_lines(&std::fs::read_to_string(&path).unwrap());
        if lines > MAX_CODE_LINES {
            over.push(format!("{}: {lines}", path.display()));
        }
    }
    assert!(
        checked > 15,
        "only {checked} command files under {}",
        dir.display()
    );
    assert!(
        over.is_empty(),
        "command files over {MAX_CODE_LINES} code lines (move what is neither parsing nor printing into the library): {over:#?}"
    );
}
