//! The report as a person sees it: opened in a real headless Chromium (Debian's `chromium`),
//! with the network unreachable, screenshotted, and checked for drawn plots.

use crate::common::*;
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
    layout_is_readable(&bin, dir, &html, 8, 8);
    let keep = std::env::var_os("HYDROFIT_SCREENSHOT");
    if let Some(path) = keep {
        std::fs::copy(&shot, path).unwrap();
    }
}

/// Measures the laid-out page in Chromium at a 1200 px wide window: every figure has a caption
/// and a drawn plot (a line of over ten points besides the axes), no table reaches past the
/// text column (a wide one scrolls inside it), and the page itself does not scroll sideways. The report forbids scripts, so
/// a copy whose policy allows one inline script (the measurement) is opened; the script writes
/// its findings into the DOM that `--dump-dom` returns.
fn layout_is_readable(
    bin: &str,
    dir: &std::path::Path,
    html: &str,
    min_figures: u64,
    min_tables: u64,
) {
    const MEASURE: &str = r#"<script>
addEventListener('load', () => {
  const width = document.documentElement.clientWidth;
  const body = document.body.getBoundingClientRect();
  const column = body.right - parseFloat(getComputedStyle(document.body).paddingRight);
  const figs = [...document.querySelectorAll('figure')];
  const out = {
    width,
    column,
    page_scroll_width: document.documentElement.scrollWidth,
    figures: figs.length,
    uncaptioned: figs.filter(f => !(f.querySelector('figcaption')?.textContent.trim())).map(f => f.id),
    empty: figs.filter(f => {
      const svg = f.querySelector('svg');
      const r = svg ? svg.getBoundingClientRect() : {width: 0, height: 0};
      const lines = svg ? [...svg.querySelectorAll('polyline')]
        .filter(p => (p.getAttribute('points') || '').trim().split(/\s+/).length > 10) : [];
      return r.width < 100 || r.height < 100 || lines.length === 0;
    }).map(f => f.id),
    tables: document.querySelectorAll('table').length,
    overflowing: [...document.querySelectorAll('table')]
      .filter(t => t.getBoundingClientRect().right > column + 1)
      .map(t => (t.querySelector('th')?.textContent || '?').trim()),
  };
  const pre = document.createElement('pre');
  pre.id = 'layout';
  pre.textContent = JSON.stringify(out);
  document.body.appendChild(pre);
});
</script>"#;
    let policy = "default-src 'none'; style-src 'unsafe-inline'; img-src data:";
    assert!(
        html.contains(policy),
        "the report's policy changed: update this test"
    );
    let measured = html
        .replacen(policy, &format!("{policy}; script-src 'unsafe-inline'"), 1)
        .replacen("</body>", &format!("{MEASURE}</body>"), 1);
    let page = dir.join("reports/layout-check.html");
    std::fs::write(&page, measured).unwrap();
    let profile = tempfile::tempdir().unwrap();
    let o = browser(
        bin,
        profile.path(),
        &[
            "--dump-dom".into(),
            "--window-size=1200,900".into(),
            "--virtual-time-budget=5000".into(),
        ],
        &format!("file://{}", page.display()),
    );
    let dom = String::from_utf8_lossy(&o.stdout);
    let json = dom
        .split("<pre id=\"layout\">")
        .nth(1)
        .and_then(|s| s.split("</pre>").next())
        .unwrap_or_else(|| {
            panic!(
                "the measurement did not run:\n{}",
                String::from_utf8_lossy(&o.stderr)
            )
        })
        .replace("&quot;", "\"")
        .replace("&amp;", "&");
    let v: serde_json::Value = serde_json::from_str(&json).unwrap();
    eprintln!("layout at 1200 px: {v}");
    assert!(v["figures"].as_u64().unwrap() >= min_figures, "{v}");
    assert!(v["tables"].as_u64().unwrap() >= min_tables, "{v}");
    assert_eq!(
        v["uncaptioned"],
        serde_json::json!([]),
        "figures without a caption: {v}"
    );
    assert_eq!(
        v["empty"],
        serde_json::json!([]),
        "figures with nothing drawn: {v}"
    );
    assert_eq!(
        v["overflowing"],
        serde_json::json!([]),
        "tables past the text column: {v}"
    );
    assert!(
        v["page_scroll_width"].as_f64().unwrap() <= v["width"].as_f64().unwrap(),
        "the page scrolls sideways: {v}"
    );
}

/// The field-trial examples' reports (ARX, integrated LS / RLS, adaptive identification) and
/// the discovery example's laid out in Chromium: every figure captioned and drawn, no table
/// past the text column.
#[test]
fn the_field_identifier_reports_are_readable_in_chromium() {
    let Some(bin) = chromium() else {
        assert!(
            std::env::var_os("CI").is_none(),
            "CI must install chromium (.ci/run does)"
        );
        eprintln!("SKIPPED: no chromium on this machine");
        return;
    };
    for (name, figures, tables) in [
        ("tank_submarine", 4, 6),
        ("dsrv", 8, 4),
        ("iver3_auv", 9, 4),
        // Discovery beyond the named effects: its residual-against-term and spectrum figures.
        ("pool_wave", 13, 20),
    ] {
        let p = example(name);
        let dir = p.path();
        ok(dir, &["build"]);
        let html = read(dir, "reports/index.html");
        layout_is_readable(&bin, dir, &html, figures, tables);
    }
}
