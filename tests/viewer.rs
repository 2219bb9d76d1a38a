//! The rollout viewer (`--html`) in a real headless browser, and the GIF (`--gif`).
//!
//! Needs Chromium (Debian's `chromium`; `.ci/run` installs it). Without it the test fails when
//! `CLOTHOPT_REQUIRE_BROWSER` is set (as in CI) and is skipped with a message otherwise.

mod common;

use common::{bin, run, stderr};
use std::path::{Path, PathBuf};
use std::process::Command;

/// The first Chromium on `PATH`.
fn chromium() -> Option<PathBuf> {
    let path = std::env::var_os("PATH")?;
    ["chromium", "chromium-browser", "google-chrome"]
        .iter()
        .flat_map(|name| std::env::split_paths(&path).map(move |dir| dir.join(name)))
        .find(|p| p.is_file())
}

/// Headless Chromium on `url` with `args`, its own profile in `dir`; returns (stdout, stderr).
fn headless(browser: &Path, dir: &Path, url: &str, args: &[&str]) -> (String, String) {
    let o = Command::new(browser)
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--hide-scrollbars",
            "--no-first-run",
            "--enable-logging=stderr",
            "--window-size=900,650",
        ])
        .arg(format!("--user-data-dir={}", dir.join("profile").display()))
        .args(args)
        .arg(url)
        .output()
        .expect("chromium runs");
    (
        String::from_utf8_lossy(&o.stdout).into_owned(),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}

/// The `data-status` attribute of the page's body, from the DOM after loading.
fn status(browser: &Path, dir: &Path, url: &str) -> (String, String) {
    let (dom, log) = headless(browser, dir, url, &["--dump-dom"]);
    let status = dom
        .split("data-status=\"")
        .nth(1)
        .and_then(|s| s.split('"').next())
        .unwrap_or("(no status)")
        .to_string();
    (status, log)
}

/// A screenshot of `url` as RGB pixels.
fn screenshot(browser: &Path, dir: &Path, url: &str, name: &str) -> Vec<[u8; 3]> {
    let file = dir.join(name);
    headless(
        browser,
        dir,
        url,
        &[&format!("--screenshot={}", file.display())],
    );
    let reader = std::fs::File::open(&file).unwrap_or_else(|e| panic!("{name}: {e}"));
    let mut reader = png::Decoder::new(std::io::BufReader::new(reader))
        .read_info()
        .expect("png header");
    let mut buf = vec![0; reader.output_buffer_size()];
    let info = reader.next_frame(&mut buf).expect("png frame");
    let step = info.color_type.samples();
    buf[..info.buffer_size()]
        .chunks(step)
        .map(|c| [c[0], c[1], c[2]])
        .collect()
}

#[test]
fn the_viewer_loads_without_errors_and_shows_the_cloth_move() {
    let Some(browser) = chromium() else {
        if std::env::var_os("CLOTHOPT_REQUIRE_BROWSER").is_some() {
            panic!("Chromium not found on PATH, and CLOTHOPT_REQUIRE_BROWSER is set");
        }
        eprintln!("skipped: no Chromium on PATH (set CLOTHOPT_REQUIRE_BROWSER to make this fail)");
        return;
    };
    let dir = common::scratch("viewer", "browser");
    let (html, gif) = (dir.join("u.html"), dir.join("u.gif"));
    let o = run(bin()
        .args(["simulate", "u_obstacle", "--html"])
        .arg(&html)
        .arg("--gif")
        .arg(&gif));
    assert!(o.status.success(), "{}", stderr(&o));
    let bytes = std::fs::read(&gif).expect("the GIF is written");
    assert!(bytes.starts_with(b"GIF89a"));
    let page = std::fs::read_to_string(&html).expect("the page is written");
    assert!(
        !page.contains("https://") && !page.contains("src="),
        "self-contained"
    );

    let url = |hash: &str| format!("file://{}#{hash}", html.display());
    let (ok, log) = status(&browser, &dir, &url("step=3"));
    assert_eq!(ok, "ok", "page status; browser log:\n{log}");
    assert!(!log.contains("Uncaught"), "console error:\n{log}");

    // The status does report errors: a page whose data lacks the states fails.
    let broken = dir.join("broken.html");
    std::fs::write(&broken, page.replacen("\"states\":", "\"statez\":", 1)).unwrap();
    let (bad, _) = status(&browser, &dir, &format!("file://{}", broken.display()));
    assert!(bad.starts_with("error: "), "broken page status: {bad}");

    let first = screenshot(&browser, &dir, &url("step=0"), "first.png");
    let last = screenshot(&browser, &dir, &url("step=10"), "last.png");
    assert_eq!(first.len(), last.len());
    let n = first.len();
    let drawn = first.iter().filter(|p| **p != [255, 255, 255]).count();
    assert!(drawn * 20 > n, "{drawn} of {n} pixels drawn at step 0");
    let changed = first.iter().zip(&last).filter(|(a, b)| a != b).count();
    assert!(
        changed * 100 > n,
        "{changed} of {n} pixels differ between steps 0 and 10"
    );
}
