//! The report as a reader sees it: a tiny eval writes `report.html`, headless Chromium loads
//! it, and the DOM it dumps must hold every section, every scene and every image, decoded
//! (a script added to a copy of the page counts the images whose `complete && naturalWidth >
//! 0` once the page has loaded).
//!
//! Skips with a message when no Chromium is installed, unless `SAHARA_REQUIRE_CHROMIUM=1`
//! (set by CI, which installs it), where a missing browser fails the test.

use clap::Parser;
use std::path::{Path, PathBuf};
use std::process::Command;

#[derive(Parser)]
struct Cli {
    #[command(flatten)]
    eval: super::Args,
}

/// The browser to drive: `$SAHARA_CHROMIUM`, else the first of the usual names on `PATH`.
fn chromium() -> Option<PathBuf> {
    if let Some(p) = std::env::var_os("SAHARA_CHROMIUM") {
        return Some(PathBuf::from(p));
    }
    let path = std::env::var_os("PATH")?;
    [
        "chromium",
        "chromium-browser",
        "google-chrome",
        "google-chrome-stable",
    ]
    .iter()
    .flat_map(|name| std::env::split_paths(&path).map(move |d| d.join(name)))
    .find(|p| p.is_file())
}

/// Appended to the page before `</body>`: writes `images OK/ALL svgs N` into `#sahara-check`.
const CHECK_SCRIPT: &str = r#"<script>
window.addEventListener('load', function () {
  var imgs = document.images, ok = 0;
  for (var i = 0; i < imgs.length; i++) {
    if (imgs[i].complete && imgs[i].naturalWidth > 0) ok++;
  }
  var m = document.createElement('div');
  m.id = 'sahara-check';
  m.textContent = 'images ' + ok + '/' + imgs.length + ' svgs ' + document.querySelectorAll('svg').length;
  document.body.appendChild(m);
});
</script>
"#;

/// The DOM of `page` after load, as headless Chromium dumps it.
fn dump_dom(browser: &Path, page: &Path, profile: &Path) -> String {
    let out = Command::new(browser)
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--disable-dev-shm-usage",
            "--no-first-run",
            "--virtual-time-budget=10000",
        ])
        .arg(format!("--user-data-dir={}", profile.display()))
        .arg("--dump-dom")
        .arg(format!("file://{}", page.display()))
        .output()
        .unwrap_or_else(|e| panic!("running {}: {e}", browser.display()));
    assert!(
        out.status.success(),
        "{} failed: {}",
        browser.display(),
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

#[test]
fn report_html_in_chromium() {
    let required = std::env::var_os("SAHARA_REQUIRE_CHROMIUM").is_some_and(|v| v != "0");
    let Some(browser) = chromium() else {
        assert!(
            !required,
            "SAHARA_REQUIRE_CHROMIUM is set but no chromium was found (PATH, $SAHARA_CHROMIUM)"
        );
        eprintln!("skipped: no chromium on PATH (install it, or set SAHARA_CHROMIUM)");
        return;
    };
    let dir = std::env::temp_dir().join(format!("sahara-browser-test-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let out = dir.join("run");
    let scenes = ["sphere_in_box:300", "city:300"];
    let builders = ["sweep", "sbvh", "binned"];
    let cli = Cli::parse_from([
        "eval",
        "--quick",
        "--scenes",
        &scenes.join(","),
        "--builders",
        &builders.join(","),
        "--width",
        "40",
        "--height",
        "30",
        "--passes",
        "3",
        "--build-runs",
        "1",
        "--threads",
        "2",
        "--no-scaling",
        "--out",
        out.to_str().unwrap(),
    ]);
    super::run(cli.eval).unwrap();
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    let page = out.join("report-check.html");
    std::fs::write(
        &page,
        html.replacen("</body>", &format!("{CHECK_SCRIPT}</body>"), 1),
    )
    .unwrap();
    let dom = dump_dom(&browser, &page, &dir.join("profile"));
    let _ = std::fs::remove_dir_all(&dir);

    for section in [
        "<h1>sahara evaluation</h1>",
        "<h2>Summary</h2>",
        "<h2>The paper's claims (from the study's saved run)</h2>",
        "<h2>Build time against trace cost",
        "<h2>Scenes: render, work heat maps",
        "<h2>Tables</h2>",
        "<h2>Trace-cost predictors</h2>",
        "<h2>How these numbers were taken</h2>",
    ] {
        assert!(dom.contains(section), "no {section} in the DOM");
    }
    // The summary comes before the plot, the plot before the images, the images before the
    // tables.
    let at = |s: &str| dom.find(s).unwrap();
    assert!(at("<h2>Summary") < at("<h2>Build time") && at("<h2>Build time") < at("<h2>Scenes"));
    assert!(at("<h2>Scenes") < at("<h2>Tables"));
    for sc in scenes {
        let name = sc.split(':').next().unwrap();
        assert!(
            dom.contains(&format!("<h3>{name}")),
            "no section for {name}"
        );
    }
    // Per scene: a render, a heat map per builder, a difference map per builder but sweep.
    let images = scenes.len() * (1 + builders.len() + builders.len() - 1);
    let marker = format!("images {images}/{images} svgs");
    assert!(
        dom.contains(&marker),
        "want '{marker}' (every image decoded); the page says: {}",
        dom.split("id=\"sahara-check\">")
            .nth(1)
            .and_then(|s| s.split('<').next())
            .unwrap_or("no marker: the check script did not run")
    );
    assert!(!dom.contains("missing image"), "an image is missing");
}
