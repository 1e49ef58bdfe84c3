//! The report as a person sees it: opened in a real headless Chromium (Debian's `chromium`),
//! with the network unreachable, screenshotted, and checked for drawn plots.

mod common;
use common::*;
use std::process::Command;

fn chromium() -> Option<String> {
    ["chromium", "chromium-browser", "google-chrome"]
        .iter()
        .find_map(|c| {
            Command::new("which")
                .arg(c)
                .output()
                .ok()
                .filter(|o| o.status.success())
                .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string())
        })
}

fn browser(
    bin: &str,
    profile: &std::path::Path,
    extra: &[String],
    url: &str,
) -> std::process::Output {
    // --proxy-server to a closed port: any request the page made would fail.
    let mut args: Vec<String> = [
        "--headless",
        "--no-sandbox",
        "--disable-gpu",
        "--disable-background-networking",
        "--disable-component-update",
        "--no-first-run",
        "--disable-sync",
        "--disable-quic",
        "--hide-scrollbars",
        "--proxy-server=http://127.0.0.1:9",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    args.push(format!("--user-data-dir={}", profile.display()));
    args.extend(extra.iter().cloned());
    args.push(url.to_string());
    duct::cmd(bin, args)
        .stdout_capture()
        .stderr_capture()
        .unchecked()
        .run()
        .unwrap()
}

#[test]
fn the_report_renders_its_plots_offline_in_chromium() {
    let Some(bin) = chromium() else {
        assert!(
            std::env::var_os("CI").is_none(),
            "CI must install chromium (.ci/run does)"
        );
        eprintln!(
            "SKIPPED: no chromium on this machine (apt-get install chromium); .ci/run installs it"
        );
        return;
    };
    let p = project();
    let dir = p.path();
    ok(dir, &["build"]);
    let html = read(dir, "reports/index.html");
    // Nothing on the page may come from the network: a CSP forbids it, and no URL points there.
    assert!(html.contains("Content-Security-Policy\" content=\"default-src 'none'"));
    for needle in ["src=\"http", "href=\"http", "url(http", "@import"] {
        assert!(
            !html.contains(needle),
            "the report references the network: {needle}"
        );
    }
    let url = format!("file://{}", dir.join("reports/index.html").display());
    let profile = tempfile::tempdir().unwrap();
    let dom = browser(&bin, profile.path(), &["--dump-dom".into()], &url);
    let dom_text = String::from_utf8_lossy(&dom.stdout);
    assert!(
        dom_text.matches("<svg").count() >= 4,
        "plots missing from the rendered DOM:\n{}",
        String::from_utf8_lossy(&dom.stderr)
    );
    assert!(dom_text.contains("X_uu"));

    let shot = dir.join("report.png");
    let o = browser(
        &bin,
        profile.path(),
        &[
            format!("--screenshot={}", shot.display()),
            "--window-size=1200,2600".into(),
        ],
        &url,
    );
    assert!(
        shot.is_file(),
        "no screenshot: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    let decoder = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(&shot).unwrap()));
    let mut reader = decoder.read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut buf).unwrap();
    let px = info.color_type.samples();
    // Plot lines are the only strongly coloured things on the page besides a dozen links:
    // count saturated pixels (max - min channel > 80).
    let coloured = buf
        .chunks(px)
        .filter(|c| c[..3].iter().max().unwrap() - c[..3].iter().min().unwrap() > 80)
        .count();
    assert!(
        coloured > 20_000,
        "plot lines not drawn: {coloured} coloured pixels"
    );
    let keep = std::env::var_os("HYDROFIT_SCREENSHOT");
    if let Some(path) = keep {
        std::fs::copy(&shot, path).unwrap();
    }
}
