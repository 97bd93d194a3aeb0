//! The pages in a real headless Chromium: no console error, no horizontal
//! overflow at A4 width; screenshots are left under target/tmp/html/.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::common;

use abba_advisor::Mode;
use abba_core::units::GlucoseUnit;
use abba_report::html::person::person_report_html;
use common::browser::assert_renders_at_a4;
use common::{out_dir, synthetic_person};

#[test]
fn person_reports_render_at_a4_width_without_errors() {
    let dir = out_dir("browser-person");
    for (name, mode, unit) in [
        ("person-cgm.html", Mode::Cgm, GlucoseUnit::MgDl),
        ("person-smbg-mmol.html", Mode::Smbg, GlucoseUnit::MmolL),
    ] {
        let page = dir.join(name);
        std::fs::write(
            &page,
            person_report_html(&synthetic_person(14, mode, unit)).unwrap(),
        )
        .unwrap();
        if let Some(shot) = assert_renders_at_a4(&page) {
            eprintln!("screenshot: {}", shot.display());
        }
    }
}

#[test]
fn the_checks_see_overflow_and_console_errors() {
    // The checks above could fail: a page wider than A4, a page with a
    // script error and a figure whose text prints too small are seen as such.
    let Some(browser) = common::browser::chromium() else {
        return;
    };
    let dir = out_dir("browser-negative");
    let wide = dir.join("wide.html");
    std::fs::write(
        &wide,
        "<!DOCTYPE html><html lang=\"en\"><head><title>w</title></head><body><div style=\"width:1500px\">wide</div></body></html>",
    )
    .unwrap();
    let r = common::browser::open_at_a4(&browser, &wide, &dir.join("wide.png"));
    assert!(r.scroll_width > r.client_width, "{r:?}");
    let broken = dir.join("broken.html");
    std::fs::write(
        &broken,
        "<!DOCTYPE html><html lang=\"en\"><head><title>b</title></head><body><script>no_such_function();</script></body></html>",
    )
    .unwrap();
    let r = common::browser::open_at_a4(&browser, &broken, &dir.join("broken.png"));
    assert!(!r.console.is_empty(), "{r:?}");
    // A figure 1000 units wide shown at the page's width: its 10-unit text
    // prints at 10 × 703 / 1000 × 0.75 ≈ 5.3 pt; a 20-unit title at 10.5.
    let small = dir.join("small.html");
    std::fs::write(
        &small,
        "<!DOCTYPE html><html lang=\"en\"><head><title>s</title><style>svg{width:100%;display:block}</style></head><body><svg xmlns=\"http://www.w3.org/2000/svg\" viewBox=\"0 0 1000 100\"><text x=\"10\" y=\"30\" font-size=\"20\">title</text><text x=\"10\" y=\"60\" font-size=\"10\">tick</text></svg></body></html>",
    )
    .unwrap();
    let r = common::browser::open_at_a4(&browser, &small, &dir.join("small.png"));
    let (pt, text) = r.smallest_figure_text.clone().unwrap();
    assert_eq!(text, "tick", "{r:?}");
    assert!(
        (pt - 10.0 * common::browser::A4_TEXT_WIDTH_PX / 1000.0 * 0.75).abs() < 0.05,
        "{r:?}"
    );
}
