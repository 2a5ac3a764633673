//! The strobe disc, inlined in an HTML page, renders in a real browser: no console errors, no empty
//! `<svg>`, and bars on the screenshot. Skips when Chromium is absent unless SPINCAL_REQUIRE_BROWSER=1.

use crate::support;

use assert_cmd::Command;

#[test]
fn strobe_disc_renders_in_chromium() {
    if support::chromium().is_none() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let svg_path = dir.path().join("disc.svg");
    Command::cargo_bin("spincal")
        .unwrap()
        .args(["strobe", "--rpm", "33.333", "--rpm", "45", "--mains", "50", "-o"])
        .arg(&svg_path)
        .assert()
        .success();
    let svg = std::fs::read_to_string(&svg_path).unwrap();
    let html = dir.path().join("strobe.html");
    std::fs::write(
        &html,
        format!("<!doctype html><html><head><meta charset=\"utf-8\"><title>disc</title></head><body style=\"margin:0\">{svg}</body></html>"),
    )
    .unwrap();
    let page = support::render(&html, dir.path()).unwrap();
    eprintln!(
        "browser took {:.2} s; screenshot {}",
        page.elapsed.as_secs_f64(),
        page.screenshot.display()
    );
    if let Ok(keep) = std::env::var("SPINCAL_KEEP_SCREENSHOT") {
        std::fs::copy(&page.screenshot, keep).unwrap();
    }
    assert!(page.console_errors.is_empty(), "{:?}", page.console_errors);
    assert_eq!(page.svg_count(), 1);
    assert_eq!(page.empty_svgs(), 0);
    assert_eq!(page.dom.matches("class=\"bar\"").count(), 180 + 133);

    // The disc is drawn: a 122 mm square is about 461 px at 96 px/in; its middle ring band is dark.
    let img = image::open(&page.screenshot).unwrap().to_rgb8();
    assert_eq!(img.dimensions(), (1280, 4000));
    let dark_in = |x0: u32, x1: u32, y0: u32, y1: u32| {
        (x0..x1)
            .flat_map(|x| (y0..y1).map(move |y| (x, y)))
            .filter(|&(x, y)| img.get_pixel(x, y)[0] < 100)
            .count()
    };
    let disc = dark_in(0, 470, 0, 470);
    assert!(disc > 20_000, "only {disc} dark pixels where the disc should be");
    assert_eq!(dark_in(600, 1280, 600, 4000), 0, "nothing drawn outside the disc");
}

#[test]
fn harness_sees_script_errors_and_empty_svgs() {
    if support::chromium().is_none() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let html = dir.path().join("broken.html");
    std::fs::write(
        &html,
        "<html><body><svg width=\"10\" height=\"10\"></svg><script>notDefined();</script></body></html>",
    )
    .unwrap();
    let page = support::render(&html, dir.path()).unwrap();
    assert_eq!(page.empty_svgs(), 1);
    assert!(
        page.console_errors.iter().any(|e| e.contains("notDefined")),
        "{:?}",
        page.console_errors
    );
}

#[test]
fn empty_svg_counting() {
    assert_eq!(
        support::count_empty_svgs("<svg a=\"1\">\n </svg><svg><g/></svg><svg/>"),
        2
    );
}
