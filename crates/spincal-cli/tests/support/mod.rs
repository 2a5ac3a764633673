//! Support shared by the CLI's integration tests: a headless-browser harness for HTML output.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// What a page looked like in a real browser.
pub struct Rendered {
    /// Full-page screenshot (1280 × 4000).
    pub screenshot: PathBuf,
    /// The DOM after scripts ran (`--dump-dom`).
    pub dom: String,
    /// Console errors and uncaught exceptions reported on stderr.
    pub console_errors: Vec<String>,
    /// Wall-clock time of both browser runs (they run in parallel).
    pub elapsed: Duration,
}

impl Rendered {
    /// `<svg>` elements whose first child is their own closing tag (drew nothing).
    pub fn empty_svgs(&self) -> usize {
        count_empty_svgs(&self.dom)
    }

    pub fn svg_count(&self) -> usize {
        self.dom.matches("<svg").count()
    }
}

/// The browser to use: `$SPINCAL_CHROMIUM`, else `/usr/bin/chromium`. `None` with a printed reason when
/// it is absent, unless `SPINCAL_REQUIRE_BROWSER=1` (CI), where absence fails the test.
pub fn chromium() -> Option<PathBuf> {
    let path = std::env::var_os("SPINCAL_CHROMIUM")
        .map(PathBuf::from)
        .unwrap_or_else(|| "/usr/bin/chromium".into());
    if path.exists() {
        return Some(path);
    }
    let required = std::env::var("SPINCAL_REQUIRE_BROWSER").is_ok_and(|v| v == "1");
    assert!(
        !required,
        "SPINCAL_REQUIRE_BROWSER=1 but {} is absent: run scripts/setup.sh",
        path.display()
    );
    eprintln!(
        "skipped: {} is absent (run scripts/setup.sh, or set SPINCAL_CHROMIUM)",
        path.display()
    );
    None
}

/// Loads `html` in headless Chromium twice, in parallel: once for a screenshot into `out_dir`, once to
/// dump the DOM; both log the console to stderr. `None` when the browser is absent (see [`chromium`]).
pub fn render(html: &Path, out_dir: &Path) -> Option<Rendered> {
    let browser = chromium()?;
    let html = html.canonicalize().expect("html file exists");
    let url = format!("file://{}", html.display());
    let screenshot = out_dir.join(format!("{}.png", html.file_stem().unwrap().to_string_lossy()));
    let start = Instant::now();
    let shot = {
        let (browser, url, out_dir, screenshot) = (
            browser.clone(),
            url.clone(),
            out_dir.to_path_buf(),
            screenshot.clone(),
        );
        std::thread::spawn(move || {
            run(
                &browser,
                &out_dir.join("profile-shot"),
                &[format!("--screenshot={}", screenshot.display())],
                &url,
            )
        })
    };
    let (dom, dump_err) = run(
        &browser,
        &out_dir.join("profile-dom"),
        &["--dump-dom".to_string()],
        &url,
    );
    let (_, shot_err) = shot.join().expect("screenshot thread");
    let elapsed = start.elapsed();
    assert!(
        screenshot.exists(),
        "chromium wrote no screenshot; stderr:\n{shot_err}"
    );
    let mut errors = console_errors(&dump_err);
    for e in console_errors(&shot_err) {
        if !errors.contains(&e) {
            errors.push(e);
        }
    }
    let console_errors = errors;
    Some(Rendered {
        screenshot,
        dom,
        console_errors,
        elapsed,
    })
}

/// Runs the browser with a fresh profile; returns (stdout, stderr). Killed after 60 s.
fn run(browser: &Path, profile: &Path, action: &[String], url: &str) -> (String, String) {
    std::fs::create_dir_all(profile).expect("profile dir");
    let mut child = Command::new(browser)
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--disable-quic",
            "--no-first-run",
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
            "--hide-scrollbars",
            "--enable-logging=stderr",
            "--v=0",
            "--window-size=1280,4000",
        ])
        .arg(format!("--user-data-dir={}", profile.display()))
        .args(action)
        .arg(url)
        .stdin(Stdio::null())
        // Files, not pipes: a large --dump-dom would fill a pipe nobody reads while we wait.
        .stdout(std::fs::File::create(profile.join("stdout.txt")).expect("stdout file"))
        .stderr(std::fs::File::create(profile.join("stderr.txt")).expect("stderr file"))
        .spawn()
        .expect("chromium starts");
    let deadline = Instant::now() + Duration::from_secs(60);
    while child.try_wait().expect("wait").is_none() {
        if Instant::now() > deadline {
            let _ = child.kill();
            panic!("chromium did not finish within 60 s on {url}");
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    let read = |name: &str| {
        String::from_utf8_lossy(&std::fs::read(profile.join(name)).unwrap_or_default()).into_owned()
    };
    (read("stdout.txt"), read("stderr.txt"))
}

/// Console errors in Chromium's stderr log: `CONSOLE` lines at error level or with "Uncaught".
pub fn console_errors(stderr: &str) -> Vec<String> {
    stderr
        .lines()
        .filter(|l| {
            l.contains("CONSOLE") && (l.contains("Uncaught") || l.contains(":ERROR:") || l.contains("Error"))
        })
        .map(str::to_string)
        .collect()
}

/// Counts `<svg …>` immediately followed (after whitespace) by `</svg>`, or self-closed.
pub fn count_empty_svgs(dom: &str) -> usize {
    dom.match_indices("<svg")
        .filter(|(i, _)| {
            let rest = &dom[i + 4..];
            let Some(end) = rest.find('>') else { return true };
            rest[..end].ends_with('/') || rest[end + 1..].trim_start().starts_with("</svg>")
        })
        .count()
}

/// `spincal demo --out spincal-demo --quiet`, run once for the whole suite in a folder of its own
/// (the demo test checks its files; the help-example test counts it as its `demo` example): the
/// folder holding `spincal-demo`, and the command's stdout. Panics when the demo fails.
pub fn demo() -> &'static (PathBuf, String) {
    static DEMO: std::sync::OnceLock<(PathBuf, String)> = std::sync::OnceLock::new();
    DEMO.get_or_init(|| {
        let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("demo-run");
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let out = Command::new(env!("CARGO_BIN_EXE_spincal"))
            .current_dir(&dir)
            .args(["demo", "--out", "spincal-demo", "--quiet"])
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "`spincal demo --out spincal-demo` exited with {:?}:\n{}",
            out.status.code(),
            String::from_utf8_lossy(&out.stderr)
        );
        (dir, String::from_utf8(out.stdout).unwrap())
    })
}
