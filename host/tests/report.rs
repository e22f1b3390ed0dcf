//! `host report` end to end: a small report made with the CPU backend, opened from file:// in
//! headless Chromium through chromedriver (WebDriver, driven by fantoccini). Checks that nothing
//! logs an error, every image loads, the estimator and mode buttons change the shown pixels, the
//! slider wipes, the inset follows a click, and the table shows the JSON's numbers; saves a
//! screenshot to target/test-artifacts/report.png.
//!
//! Needs Debian's `chromium` and `chromium-driver` (`./scripts/test.sh` installs them); without
//! them the test fails and says so.

use fantoccini::actions::{InputSource, MouseActions, PointerAction, MOUSE_BUTTON_LEFT};
use fantoccini::wd::WebDriverCompatibleCommand;
use fantoccini::{Client, ClientBuilder, Locator};
use serde_json::{json, Value};
use std::net::{TcpListener, TcpStream};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

const CHROMIUM: &str = "/usr/bin/chromium";
const CHROMEDRIVER: &str = "/usr/bin/chromedriver";

fn host() -> Command {
    Command::new(env!("CARGO_BIN_EXE_host"))
}

/// `target/`: the parent of Cargo's per-test temporary directory `target/tmp`.
fn target_dir() -> PathBuf {
    Path::new(env!("CARGO_TARGET_TMPDIR"))
        .parent()
        .expect("CARGO_TARGET_TMPDIR has a parent")
        .to_path_buf()
}

fn run_ok(cmd: &mut Command) -> String {
    let out = cmd.output().expect("running host");
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(
        out.status.success(),
        "{cmd:?} failed\n{stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    stdout
}

/// chromedriver on a free local port, killed on drop.
struct Driver {
    child: Child,
    port: u16,
    log: PathBuf,
}

impl Driver {
    fn start(dir: &Path) -> Driver {
        for (path, package) in [(CHROMIUM, "chromium"), (CHROMEDRIVER, "chromium-driver")] {
            assert!(
                Path::new(path).is_file(),
                "{path} is missing: run ./scripts/test.sh, which installs Debian's {package} \
                 (or `apt-get install chromium chromium-driver`)"
            );
        }
        let port = TcpListener::bind("127.0.0.1:0")
            .and_then(|l| l.local_addr())
            .expect("a free port")
            .port();
        let log = dir.join("chromedriver.log");
        let child = Command::new(CHROMEDRIVER)
            .arg(format!("--port={port}"))
            .arg(format!("--log-path={}", log.display()))
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .expect("starting chromedriver");
        let driver = Driver { child, port, log };
        let start = Instant::now();
        while TcpStream::connect(("127.0.0.1", port)).is_err() {
            assert!(
                start.elapsed() < Duration::from_secs(30),
                "chromedriver did not listen on port {port} within 30 s (log: {})",
                driver.log.display()
            );
            std::thread::sleep(Duration::from_millis(50));
        }
        driver
    }
}

impl Drop for Driver {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// A chromedriver-specific POST on the session (`se/log`, `goog/cdp/execute`).
#[derive(Debug)]
struct SessionPost {
    path: &'static str,
    body: Value,
}

impl WebDriverCompatibleCommand for SessionPost {
    fn endpoint(
        &self,
        base_url: &url::Url,
        session_id: Option<&str>,
    ) -> Result<url::Url, url::ParseError> {
        base_url.join(&format!(
            "session/{}/{}",
            session_id.unwrap_or_default(),
            self.path
        ))
    }

    fn method_and_body(&self, _: &url::Url) -> (http::Method, Option<String>) {
        (http::Method::POST, Some(self.body.to_string()))
    }
}

/// Installed by the test (CDP) before any script of the page runs, so the page cannot hide
/// its errors from it.
const ERROR_PROBE: &str = r#"
window.__testErrors = [];
window.addEventListener('error', function (e) {
  var t = e.target;
  window.__testErrors.push(t && t !== window && (t.src || t.href)
    ? 'failed to load ' + (t.src || t.href) : 'error: ' + e.message);
}, true);
window.addEventListener('unhandledrejection', function (e) {
  window.__testErrors.push('unhandled rejection: ' + e.reason);
});
(function () {
  var error = console.error, warn = console.warn;
  console.error = function () { window.__testErrors.push('console.error: ' + Array.prototype.join.call(arguments, ' ')); return error.apply(console, arguments); };
  console.warn = function () { window.__testErrors.push('console.warn: ' + Array.prototype.join.call(arguments, ' ')); return warn.apply(console, arguments); };
})();
"#;

type R<T> = Result<T, Box<dyn std::error::Error>>;

async fn js(c: &Client, script: &str) -> R<Value> {
    Ok(c.execute(script, vec![]).await?)
}

/// Waits until every <img> has finished (loaded or failed) and returns
/// [src, complete, naturalWidth] of each.
async fn images(c: &Client) -> R<Vec<(String, bool, u64)>> {
    let script =
        "return Array.from(document.images).map(i => [i.src, i.complete, i.naturalWidth]);";
    let start = Instant::now();
    loop {
        let v = js(c, script).await?;
        let list: Vec<(String, bool, u64)> = serde_json::from_value(v)?;
        if list.iter().all(|(_, complete, _)| *complete) || start.elapsed().as_secs() > 10 {
            return Ok(list);
        }
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
}

async fn assert_images_load(c: &Client, what: &str) -> R<usize> {
    let list = images(c).await?;
    assert!(!list.is_empty(), "{what}: no <img> on the page");
    let broken: Vec<_> = list.iter().filter(|(_, ok, w)| !ok || *w == 0).collect();
    assert!(broken.is_empty(), "{what}: images did not load: {broken:?}");
    Ok(list.len())
}

/// Every error recorded by the probe, the page's own hook, and Chromium's browser log.
async fn errors(c: &Client) -> R<Vec<String>> {
    let mut all: Vec<String> = serde_json::from_value(
        js(
            c,
            "return (window.__testErrors || ['error probe missing']).concat(window.__errors || []);",
        )
        .await?,
    )?;
    let log = c
        .issue_cmd(SessionPost {
            path: "se/log",
            body: json!({ "type": "browser" }),
        })
        .await?;
    let log = log
        .as_array()
        .ok_or_else(|| format!("chromedriver's browser log is not a list: {log}"))?;
    for entry in log {
        let level = entry["level"].as_str().unwrap_or("");
        if level == "SEVERE" || level == "WARNING" {
            all.push(format!("browser log {level}: {}", entry["message"]));
        }
    }
    Ok(all)
}

fn decode(png: &[u8]) -> image::RgbaImage {
    image::load_from_memory(png)
        .expect("screenshot is a PNG")
        .to_rgba8()
}

/// Screenshot of one element, decoded.
async fn shot(c: &Client, css: &str) -> R<image::RgbaImage> {
    let e = c.find(Locator::Css(css)).await?;
    Ok(decode(&e.screenshot().await?))
}

fn distinct_colours(img: &image::RgbaImage) -> usize {
    let mut v: Vec<[u8; 4]> = img.pixels().map(|p| p.0).collect();
    v.sort_unstable();
    v.dedup();
    v.len()
}

async fn click(c: &Client, css: &str) -> R<()> {
    c.find(Locator::Css(css)).await?.click().await?;
    Ok(())
}

async fn src_of(c: &Client, css: &str) -> R<String> {
    Ok(c.find(Locator::Css(css))
        .await?
        .prop("src")
        .await?
        .unwrap_or_default())
}

async fn drive(c: &Client, index: &Path, report: &Path, artifact: &Path) -> R<()> {
    c.issue_cmd(SessionPost {
        path: "goog/cdp/execute",
        body: json!({ "cmd": "Page.addScriptToEvaluateOnNewDocument",
                      "params": { "source": ERROR_PROBE } }),
    })
    .await?;
    c.set_window_size(1280, 1500).await?;
    let url = url::Url::from_file_path(index).expect("absolute path");
    c.goto(url.as_str()).await?;
    assert_eq!(
        js(c, "return window.__viewerReady === true;").await?,
        json!(true),
        "the viewer did not finish starting: {:?}",
        errors(c).await?
    );
    let eval: Value =
        serde_json::from_str(&std::fs::read_to_string(report.join("cloud/eval.json"))?)?;

    // Every mode: all images load, and the left pane shows the left estimator's PNG of it.
    // Two panes and an inset per estimator, plus the reference's inset in render mode.
    for (mode, field, count) in [
        ("bias", "bias_png", 2 + 3),
        ("std", "std_png", 2 + 3),
        ("render", "mean_png", 2 + 4),
    ] {
        click(c, &format!("#modes button[data-value={mode}]")).await?;
        let n = assert_images_load(c, mode).await?;
        assert_eq!(n, count, "{mode}: number of images");
        let src = src_of(c, "#pane-left img.main").await?;
        let file = Path::new(eval["estimators"][0][field].as_str().unwrap())
            .file_name()
            .unwrap()
            .to_string_lossy()
            .into_owned();
        assert!(src.ends_with(&format!("/cloud/{file}")), "{mode}: {src}");
    }

    // Switching the left estimator changes the image's source and the pixels shown.
    let before_src = src_of(c, "#pane-left img.main").await?;
    let before = shot(c, "#pane-left .frame").await?;
    assert!(
        distinct_colours(&before) > 8,
        "the render looks blank: {} colours",
        distinct_colours(&before)
    );
    click(c, "#pick-left button[data-value=ratio]").await?;
    assert_images_load(c, "after switching").await?;
    let after_src = src_of(c, "#pane-left img.main").await?;
    assert_ne!(before_src, after_src);
    assert!(after_src.ends_with("/cloud/ratio_mean.png"), "{after_src}");
    let after = shot(c, "#pane-left .frame").await?;
    assert_eq!(before.dimensions(), after.dimensions());
    let changed = before
        .pixels()
        .zip(after.pixels())
        .filter(|(a, b)| a != b)
        .count();
    assert!(
        changed > 100,
        "switching jackknife -> ratio changed only {changed} pixels"
    );

    // The reference selected in bias mode shows a note, not a broken image.
    click(c, "#modes button[data-value=bias]").await?;
    click(c, "#pick-right button[data-value=reference]").await?;
    assert_images_load(c, "reference in bias mode").await?;
    let note = c
        .find(Locator::Css("#pane-right .missing"))
        .await?
        .text()
        .await?;
    assert!(note.contains("reference"), "{note}");
    click(c, "#pick-right button[data-value=naive]").await?;

    // Slider: both images under one frame; dragging moves the wipe and changes the pixels.
    click(c, "#views button[data-view=slider]").await?;
    assert_images_load(c, "slider").await?;
    assert_eq!(
        c.find_all(Locator::Css("#pane-slider img.main"))
            .await?
            .len(),
        2
    );
    let wipe = |c: &Client| {
        let c = c.clone();
        async move { js(&c, "return window.viewer.state.wipe;").await }
    };
    assert_eq!(wipe(c).await?, json!(50));
    let wide = shot(c, "#wipe-frame").await?;
    let frame = c.find(Locator::Css("#wipe-frame")).await?;
    let (_, _, w, _) = frame.rectangle().await?;
    let drag = MouseActions::new("mouse".into())
        .then(PointerAction::MoveToElement {
            element: frame.clone(),
            duration: None,
            x: 0.0,
            y: 0.0,
        })
        .then(PointerAction::Down {
            button: MOUSE_BUTTON_LEFT,
        })
        .then(PointerAction::MoveBy {
            duration: Some(Duration::from_millis(100)),
            x: -0.4 * w,
            y: 0.0,
        })
        .then(PointerAction::Up {
            button: MOUSE_BUTTON_LEFT,
        });
    c.perform_actions(drag).await?;
    let moved = wipe(c).await?.as_f64().unwrap();
    assert!((5.0..15.0).contains(&moved), "wipe after dragging: {moved}");
    let narrow = shot(c, "#wipe-frame").await?;
    let changed = wide
        .pixels()
        .zip(narrow.pixels())
        .filter(|(a, b)| a != b)
        .count();
    assert!(
        changed > 100,
        "dragging the slider changed {changed} pixels"
    );
    click(c, "#views button[data-view=side]").await?;

    // A click on the image moves the inset region there.
    let main = c.find(Locator::Css("#pane-left .frame")).await?;
    let (_, _, w, h) = main.rectangle().await?;
    let at = MouseActions::new("mouse".into())
        .then(PointerAction::MoveToElement {
            element: main,
            duration: None,
            x: 0.3 * w,
            y: -0.3 * h,
        })
        .then(PointerAction::Down {
            button: MOUSE_BUTTON_LEFT,
        })
        .then(PointerAction::Up {
            button: MOUSE_BUTTON_LEFT,
        });
    c.perform_actions(at).await?;
    let xy = js(c, "return [window.viewer.state.x, window.viewer.state.y];").await?;
    let (x, y) = (xy[0].as_u64().unwrap(), xy[1].as_u64().unwrap());
    assert!(
        (24..=27).contains(&x) && (4..=7).contains(&y),
        "inset centre after a click at (80%, 20%) of 32 x 32: ({x}, {y})"
    );
    assert_images_load(c, "insets after the click").await?;

    // The table shows the JSON's numbers (the page formats them, the values stay exact).
    for e in eval["estimators"].as_array().unwrap() {
        let name = e["name"].as_str().unwrap();
        for key in [
            "mean_bias",
            "mean_abs_bias",
            "abs_bias_noise_floor",
            "mean_std",
            "rmse",
            "mean_samples_per_ray",
            "elapsed_ms",
        ] {
            let cell = c
                .find(Locator::Css(&format!(
                    "#numbers tr[data-name=\"{name}\"] td[data-key={key}]"
                )))
                .await?;
            let shown: f64 = cell.attr("data-value").await?.unwrap().parse()?;
            assert_eq!(shown, e[key].as_f64().unwrap(), "{name} {key}");
        }
    }

    // The colour bar of the bias mode is drawn from the JSON's colour map.
    click(c, "#modes button[data-value=bias]").await?;
    let ticks = c
        .find(Locator::Css("#colourbar .ticks"))
        .await?
        .text()
        .await?;
    let min = eval["bias_colour_map"]["min"].as_f64().unwrap();
    assert!(
        ticks.contains(&min.to_string()),
        "ticks {ticks:?}, min {min}"
    );

    std::fs::write(artifact, c.screenshot().await?)?;
    let errors = errors(c).await?;
    assert!(errors.is_empty(), "errors in the page: {errors:#?}");
    Ok(())
}

#[test]
fn report_opens_in_headless_chromium() {
    let tmp = tempfile::tempdir_in(env!("CARGO_TARGET_TMPDIR")).unwrap();
    let report = tmp.path().join("report");
    run_ok(host().args([
        "report",
        "--backend",
        "cpu",
        "--volumes",
        "cloud",
        "--resolution",
        "64",
        "--width",
        "32",
        "--height",
        "32",
        "--spp",
        "4",
        "--estimators",
        "jackknife,naive,ratio",
        "--quiet",
        "--out",
        report.to_str().unwrap(),
    ]));
    let index = report.join("index.html");
    assert!(index.is_file());
    let artifacts = target_dir().join("test-artifacts");
    std::fs::create_dir_all(&artifacts).unwrap();
    let artifact = artifacts.join("report.png");
    let _ = std::fs::remove_file(&artifact);

    let driver = Driver::start(tmp.path());
    let profile = tmp.path().join("chromium-profile");
    let caps = json!({
        "browserName": "chrome",
        "goog:loggingPrefs": { "browser": "ALL" },
        "goog:chromeOptions": {
            "binary": CHROMIUM,
            "args": [
                "--headless=new", "--no-sandbox", "--disable-gpu", "--disable-quic",
                "--no-first-run", "--disable-background-networking",
                "--disable-component-update", "--disable-sync",
                "--hide-scrollbars", "--force-device-scale-factor=1",
                format!("--user-data-dir={}", profile.display()),
            ],
        },
    });
    let rt = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .unwrap();
    let local = tokio::task::LocalSet::new();
    let result: R<()> = local.block_on(&rt, async {
        let client = ClientBuilder::new(hyper_util::client::legacy::connect::HttpConnector::new())
            .capabilities(caps.as_object().unwrap().clone())
            .connect(&format!("http://127.0.0.1:{}/", driver.port))
            .await?;
        // A failed assertion must still end the browser session (else Chromium outlives the
        // test): run the checks as a task, whose panic comes back as a JoinError.
        let (c, i, r, a) = (
            client.clone(),
            index.clone(),
            report.clone(),
            artifact.clone(),
        );
        let outcome = tokio::task::spawn_local(async move { drive(&c, &i, &r, &a).await }).await;
        client.close().await?;
        match outcome {
            Ok(result) => result,
            Err(e) => std::panic::resume_unwind(e.into_panic()),
        }
    });
    if let Err(e) = result {
        panic!(
            "browser test failed: {e}\n(chromedriver log: {})",
            driver.log.display()
        );
    }
    assert!(artifact.is_file());
    let shot = image::open(&artifact).unwrap().to_rgb8();
    assert!(
        shot.width() >= 1000 && shot.height() >= 800,
        "{:?}",
        shot.dimensions()
    );
    drop(driver);
}

#[test]
fn report_errors_name_the_file() {
    let tmp = tempfile::tempdir_in(env!("CARGO_TARGET_TMPDIR")).unwrap();
    let fail = |args: &[&str]| -> String {
        let out = host().args(args).output().unwrap();
        assert!(!out.status.success(), "{args:?} succeeded");
        String::from_utf8_lossy(&out.stderr).into_owned()
    };
    let out = tmp.path().join("out");
    let out = out.to_str().unwrap();

    let missing = tmp.path().join("no-such-eval");
    let err = fail(&[
        "report",
        "--out",
        out,
        "--from-eval",
        missing.to_str().unwrap(),
    ]);
    assert!(
        err.contains("no-such-eval") && err.contains("no such file"),
        "{err}"
    );

    let empty = tmp.path().join("empty");
    std::fs::create_dir_all(&empty).unwrap();
    let err = fail(&[
        "report",
        "--out",
        out,
        "--from-eval",
        empty.to_str().unwrap(),
    ]);
    assert!(err.contains("no eval.json"), "{err}");

    let bad = tmp.path().join("bad.json");
    std::fs::write(&bad, "{ \"volume\": ").unwrap();
    let err = fail(&["report", "--out", out, "--from-eval", bad.to_str().unwrap()]);
    assert!(
        err.contains("bad.json") && err.contains("not valid JSON"),
        "{err}"
    );

    // An eval.json from before `host report` (no mean_png; kept in host/tests/data): says which
    // file and why.
    let old = tmp.path().join("old");
    std::fs::create_dir_all(&old).unwrap();
    std::fs::copy(
        concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/tests/data/eval_before_report.json"
        ),
        old.join("eval.json"),
    )
    .unwrap();
    let err = fail(&["report", "--out", out, "--from-eval", old.to_str().unwrap()]);
    assert!(
        err.contains("eval.json") && err.contains("missing field"),
        "{err}"
    );
}

#[test]
fn report_reuses_eval_output_and_integrators() {
    let tmp = tempfile::tempdir_in(env!("CARGO_TARGET_TMPDIR")).unwrap();
    let eval = tmp.path().join("eval");
    let mis = tmp.path().join("mis");
    let common = [
        "--backend",
        "cpu",
        "--resolution",
        "32",
        "--width",
        "8",
        "--height",
        "8",
        "--quiet",
    ];
    run_ok(
        host()
            .args(["eval", "--spp", "2", "--estimators", "jackknife,ratio"])
            .args(common)
            .arg("--out-dir")
            .arg(&eval),
    );
    run_ok(
        host()
            .args([
                "eval",
                "--spp",
                "2",
                "--reference-spp",
                "4",
                "--integrators",
                "free-flight,mis-jackknife",
            ])
            .args(common)
            .arg("--out-dir")
            .arg(&mis),
    );
    let report = tmp.path().join("report");
    run_ok(
        host()
            .args(["report", "--from-eval"])
            .arg(&eval)
            .arg("--from-eval")
            .arg(mis.join("eval.json"))
            .arg("--out")
            .arg(&report),
    );
    let html = std::fs::read_to_string(report.join("index.html")).unwrap();
    // Everything the page links is inside the report directory, by relative path.
    for file in [
        "eval/eval.json",
        "eval/reference.png",
        "eval/jackknife_mean.png",
        "eval/ratio_std.exr",
        "mis/eval.json",
        "mis/mis-jackknife.png",
        "mis/free-flight.exr",
        "mis/reference.exr",
    ] {
        assert!(report.join(file).is_file(), "{file} not copied");
        assert!(html.contains(&format!("\"{file}\"")), "{file} not linked");
    }
    assert!(!html.contains("__REPORT_DATA__"));
    assert!(
        !html.contains(tmp.path().to_str().unwrap()),
        "absolute paths in the page"
    );
}

/// `host report`'s scene flags reach its evaluations: its reference image equals that of
/// `host eval` with the same `--density-scale`, `--camera`, `--look-at`, `--fov` and `--up`
/// (issue 43, item 10: the flags did not exist).
#[test]
fn report_scene_flags_reach_the_evaluations() {
    let tmp = tempfile::tempdir_in(env!("CARGO_TARGET_TMPDIR")).unwrap();
    let scene = [
        "--density-scale",
        "40",
        "--camera",
        "0.2,0.9,-2.5",
        "--look-at",
        "0,0.1,0",
        "--fov",
        "31",
        "--up",
        "z",
    ];
    let common = [
        "--backend",
        "cpu",
        "--resolution",
        "24",
        "--width",
        "12",
        "--height",
        "10",
        "--spp",
        "2",
        "--estimators",
        "jackknife",
        "--quiet",
    ];
    let eval = tmp.path().join("eval");
    run_ok(
        host()
            .arg("eval")
            .args(common)
            .args(scene)
            .arg("--out-dir")
            .arg(&eval),
    );
    let report = tmp.path().join("report");
    run_ok(
        host()
            .args(["report", "--volumes", "cloud"])
            .args(common)
            .args(scene)
            .arg("--out")
            .arg(&report),
    );
    let plain = tmp.path().join("plain");
    run_ok(
        host()
            .args(["report", "--volumes", "cloud"])
            .args(common)
            .arg("--out")
            .arg(&plain),
    );
    let read = |p: PathBuf| std::fs::read(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
    let from_eval = read(eval.join("reference.exr"));
    assert_eq!(read(report.join("cloud/reference.exr")), from_eval);
    assert_ne!(read(plain.join("cloud/reference.exr")), from_eval);
}
