//! The web page in a real browser (issue 16): headless Chromium driven over WebDriver
//! (`chromedriver`, installed by `scripts/install-test-deps` when missing) against the real
//! `slam-service` (with a bearer token) and `simulator` processes.
//!
//! Through the page only: the token typed in its field; a file that is no image refused in
//! the API's words; `paper-env1` sketch A uploaded through its file input; the start marked by a click and a drag on the drawing, and the
//! scale by a drawn line and its typed length; the session started. Then the simulator runs
//! in lock-step and the page's DOM must show the scan count rising, the robot marker moving
//! on the map and on the drawing, and the map picture changing; an unchanged map must be
//! answered `304` (the page's `If-None-Match`). Full-page screenshots (before, during,
//! after) go to `target/test-output/web-page/`.

mod common;

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use anyhow::{Context, Result, bail, ensure};
use common::{TempDir, dump_log, paper_env1_sketch_a, spawn_simulator_lockstep, start_service};
use fantoccini::actions::{InputSource, MOUSE_BUTTON_LEFT, MouseActions, PointerAction};
use fantoccini::{Client, ClientBuilder, Locator};
use serde_json::{Value, json};
use sketchslam_tests::processes::{ChildGuard, free_port, unique_prefix, workspace_root};

const TOKEN: &str = "page-test-token";
const SCANS: u64 = 300;
/// The scale line drawn on the drawing, image pixels, and the length typed for it.
const SCALE_LINE_PX: f64 = 200.0;
const SCALE_LINE_M: f64 = 20.0;

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_user_maps_paper_env1_through_the_page() -> Result<()> {
    let dir = TempDir::new("webpage")?;
    let data = dir.0.join("data");
    let shots = workspace_root().join("target/test-output/web-page");
    std::fs::create_dir_all(&shots)?;
    let result = run(&dir.0, &data, &shots).await;
    if result.is_err() {
        dump_log(&data.with_extension("log"), 60);
        dump_log(&dir.0.join("chromedriver.log"), 30);
    }
    result
}

/// `chromedriver`: `$CHROMEDRIVER`, else on the PATH, else Debian's.
fn chromedriver() -> Result<PathBuf> {
    if let Some(p) = std::env::var_os("CHROMEDRIVER") {
        return Ok(PathBuf::from(p));
    }
    let on_path = std::env::var_os("PATH")
        .into_iter()
        .flat_map(|p| std::env::split_paths(&p).collect::<Vec<_>>())
        .map(|d| d.join("chromedriver"))
        .find(|p| p.is_file());
    on_path
        .or_else(|| Some(PathBuf::from("/usr/bin/chromedriver")).filter(|p| p.is_file()))
        .context(
            "chromedriver is not installed: run scripts/install-test-deps (the README's test \
             command does), or set CHROMEDRIVER",
        )
}

/// `chromium` (or `$CHROME`).
fn chromium() -> Result<PathBuf> {
    if let Some(p) = std::env::var_os("CHROME") {
        return Ok(PathBuf::from(p));
    }
    [
        "/usr/bin/chromium",
        "/usr/bin/chromium-browser",
        "/usr/bin/google-chrome",
    ]
    .iter()
    .map(PathBuf::from)
    .find(|p| p.is_file())
    .context("chromium is not installed: run scripts/install-test-deps, or set CHROME")
}

async fn start_chromedriver(dir: &Path) -> Result<(ChildGuard, String)> {
    let port = free_port()?;
    let log = std::fs::File::create(dir.join("chromedriver.log"))?;
    let mut cmd = Command::new(chromedriver()?);
    cmd.arg(format!("--port={port}"))
        .stdout(Stdio::null())
        .stderr(log);
    let mut guard = ChildGuard::spawn("chromedriver", &mut cmd)?;
    let url = format!("http://127.0.0.1:{port}");
    let deadline = Instant::now() + Duration::from_secs(20);
    while reqwest::get(format!("{url}/status")).await.is_err() {
        if let Some(status) = guard.child_mut().try_wait()? {
            bail!("chromedriver exited at start: {status}");
        }
        ensure!(Instant::now() < deadline, "chromedriver did not start");
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
    Ok((guard, url))
}

async fn browser(driver: &str, profile: &Path) -> Result<Client> {
    let mut caps = serde_json::Map::new();
    caps.insert(
        "goog:chromeOptions".into(),
        json!({
            "binary": chromium()?,
            "args": [
                "--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage",
                "--window-size=1280,800", "--no-first-run", "--disable-quic",
                "--disable-background-networking", "--disable-component-update",
                "--disable-sync", "--hide-scrollbars",
                format!("--user-data-dir={}", profile.display()),
            ],
        }),
    );
    let connector = hyper_util::client::legacy::connect::HttpConnector::new();
    ClientBuilder::new(connector)
        .capabilities(caps)
        .connect(driver)
        .await
        .context("starting headless Chromium through chromedriver")
}

/// Waits until `script` (a function body returning a value) returns something truthy.
async fn wait_js(c: &Client, script: &str, timeout: Duration, what: &str) -> Result<Value> {
    let deadline = Instant::now() + timeout;
    loop {
        let v = c.execute(script, vec![]).await?;
        if !(v.is_null() || v == json!(false) || v == json!("") || v == json!(0)) {
            return Ok(v);
        }
        if Instant::now() > deadline {
            let errors = c
                .execute(
                    "return [...document.querySelectorAll('.error')].map(e => e.id + ': ' + e.textContent)",
                    vec![],
                )
                .await
                .unwrap_or_default();
            bail!("timed out after {timeout:?} waiting for {what}; page errors: {errors}");
        }
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
}

/// A screenshot of the whole page: the window grown to the document's height first (again
/// until the height holds: the page's views are sized by the window's height).
async fn full_page_screenshot(c: &Client, path: &Path, width: u32) -> Result<()> {
    c.set_window_size(width, 800).await?;
    for _ in 0..4 {
        // The window's own frame (outer − inner height) comes on top of the page's height.
        let v = c
            .execute(
                "window.scrollTo(0, 0);
                 return [document.documentElement.scrollHeight, window.innerHeight,
                         window.outerHeight - window.innerHeight];",
                vec![],
            )
            .await?;
        let n = |i: usize| v[i].as_f64().unwrap_or(0.0) as u32;
        let (page, inner, frame) = (n(0), n(1), n(2));
        if page <= inner {
            break;
        }
        c.set_window_size(width, (page + frame).clamp(800, 6000))
            .await?;
        tokio::time::sleep(Duration::from_millis(300)).await;
    }
    std::fs::write(path, c.screenshot().await?)?;
    c.set_window_size(1280, 800).await?;
    Ok(())
}

/// Viewport coordinates of drawing pixel (u, v) in the start view (scrolled into view).
async fn drawing_point(c: &Client, u: f64, v: f64) -> Result<(f64, f64)> {
    let p = c
        .execute(
            "const svg = document.getElementById('start-svg');
             svg.scrollIntoView({block: 'center'});
             const p = new DOMPoint(arguments[0], arguments[1]).matrixTransform(svg.getScreenCTM());
             return [p.x, p.y];",
            vec![json!(u), json!(v)],
        )
        .await?;
    let x = p[0].as_f64().context("x")?;
    let y = p[1].as_f64().context("y")?;
    Ok((x, y))
}

/// Presses the mouse at drawing pixel `from`, drags through to `to` and releases.
async fn drag_on_drawing(c: &Client, from: (f64, f64), to: (f64, f64)) -> Result<()> {
    let a = drawing_point(c, from.0, from.1).await?;
    let b = drawing_point(c, to.0, to.1).await?;
    let mut mouse = MouseActions::new("mouse".into())
        .then(PointerAction::MoveTo {
            duration: None,
            x: a.0.round(),
            y: a.1.round(),
        })
        .then(PointerAction::Down {
            button: MOUSE_BUTTON_LEFT,
        });
    for k in 1..=5 {
        let t = f64::from(k) / 5.0;
        mouse = mouse.then(PointerAction::MoveTo {
            duration: Some(Duration::from_millis(20)),
            x: (a.0 + t * (b.0 - a.0)).round(),
            y: (a.1 + t * (b.1 - a.1)).round(),
        });
    }
    mouse = mouse.then(PointerAction::Up {
        button: MOUSE_BUTTON_LEFT,
    });
    c.perform_actions(mouse).await?;
    Ok(())
}

/// What the live view shows now.
async fn live_state(c: &Client) -> Result<Value> {
    Ok(c.execute(
        "const mark = (id) => {
           const g = document.querySelector('#' + id + ' g[data-name=robot]');
           return g ? [Number(g.dataset.u), Number(g.dataset.v)] : null;
         };
         return {
           scans: Number(document.getElementById('h-scans').textContent),
           state: document.getElementById('h-state').textContent,
           map: mark('map-svg'),
           drawing: mark('drawing-svg'),
           refreshes: Number(document.getElementById('map-svg').dataset.refreshes || 0),
           mapHref: document.querySelector('#map-svg image')?.getAttribute('href') || null,
         };",
        vec![],
    )
    .await?)
}

fn moved(a: &Value, b: &Value) -> f64 {
    let (Some(a), Some(b)) = (a.as_array(), b.as_array()) else {
        return 0.0;
    };
    let d = |i: usize| b[i].as_f64().unwrap_or(0.0) - a[i].as_f64().unwrap_or(0.0);
    d(0).hypot(d(1))
}

async fn run(dir: &Path, data: &Path, shots: &Path) -> Result<()> {
    let prefix = unique_prefix("webpage");
    let service = start_service(data, &prefix, &[], &[("SKETCHSLAM_TOKEN", TOKEN)]).await?;
    let (_driver_guard, driver) = start_chromedriver(dir).await?;
    let c = browser(&driver, &dir.join("profile")).await?;
    let result = drive(&c, &service.base, &prefix, shots).await;
    let _ = c.close().await;
    result
}

async fn drive(c: &Client, base: &str, prefix: &str, shots: &Path) -> Result<()> {
    let (_, sketch) = paper_env1_sketch_a()?;
    let (start_u, start_v) = (sketch.start_u_px, sketch.start_v_px);
    let start_heading = sketch.start_heading_rad.to_degrees();

    c.goto(&format!("{base}/")).await?;
    // Without the token the page says so in words.
    wait_js(
        c,
        "return document.getElementById('service-status').textContent.includes('token')",
        Duration::from_secs(10),
        "the page to ask for a token",
    )
    .await?;
    c.find(Locator::Id("token"))
        .await?
        .send_keys(&format!("{TOKEN}\u{E004}"))
        .await?;
    wait_js(
        c,
        "return document.getElementById('service-status').textContent === 'connected'",
        Duration::from_secs(10),
        "the page to connect with the token",
    )
    .await?;
    // What the page was refused without the token is no longer shown.
    let stale = c
        .execute(
            "return document.getElementById('upload-error').textContent",
            vec![],
        )
        .await?;
    ensure!(
        stale == json!(""),
        "a stale error stays on the page: {stale}"
    );
    full_page_screenshot(c, &shots.join("1-before.png"), 1280).await?;

    // A file that is no drawing: refused, and the page says why in the API's words.
    let bogus = shots.join("not-a-drawing.png");
    std::fs::write(&bogus, b"this is text, not a PNG")?;
    c.find(Locator::Id("file-input"))
        .await?
        .send_keys(&std::fs::canonicalize(&bogus)?.display().to_string())
        .await?;
    let refusal = wait_js(
        c,
        "return document.getElementById('upload-error').textContent",
        Duration::from_secs(10),
        "the refusal of a bogus upload",
    )
    .await?;
    std::fs::remove_file(&bogus)?;
    ensure!(
        refusal.as_str().is_some_and(|r| r.contains("422")),
        "refusal shown: {refusal}"
    );

    // Upload through the file input, with the drawing's scale declared.
    c.find(Locator::Id("sketch-mpp"))
        .await?
        .send_keys(&sketch.meters_per_pixel.to_string())
        .await?;
    let image = std::fs::canonicalize(&sketch.image)?;
    c.find(Locator::Id("file-input"))
        .await?
        .send_keys(&image.display().to_string())
        .await?;
    let status = wait_js(
        c,
        "return document.getElementById('start-svg').dataset.sketch
            && document.getElementById('upload-status').textContent",
        Duration::from_secs(30),
        "the upload",
    )
    .await?;
    ensure!(
        status.as_str().is_some_and(|s| s.contains("lines found")),
        "upload status: {status}"
    );
    // The declared scale is the drawing's: listed with it, and the start form starts from it.
    let declared = c
        .execute(
            "return [document.getElementById('sketch-list').textContent,
                     document.getElementById('mpp').value]",
            vec![],
        )
        .await?;
    let scale = sketch.meters_per_pixel.to_string();
    ensure!(
        declared[0]
            .as_str()
            .is_some_and(|t| t.contains(&format!("{scale} m/px")))
            && declared[1] == json!(scale),
        "the declared scale {scale} is not on the page: {declared}"
    );
    let labels = c
        .execute(
            "return document.querySelectorAll('#start-svg line.sketch-line').length",
            vec![],
        )
        .await?;
    ensure!(
        labels.as_u64().unwrap_or(0) >= 4,
        "lines on the drawing: {labels}"
    );

    // The start: press at the marked pixel, drag 60 px along the heading.
    let h = start_heading.to_radians();
    let ahead = (start_u + 60.0 * h.cos(), start_v - 60.0 * h.sin());
    drag_on_drawing(c, (start_u, start_v), ahead).await?;
    let marked = c
        .execute(
            "return ['start-u', 'start-v', 'start-heading'].map(id => Number(document.getElementById(id).value))",
            vec![],
        )
        .await?;
    let m = |i: usize| marked[i].as_f64().unwrap_or(f64::NAN);
    // A CSS pixel is under 1.5 drawing pixels at this window size; the drag's rounding
    // to whole CSS pixels moves the heading by under 2°.
    ensure!(
        (m(0) - start_u).abs() < 2.0 && (m(1) - start_v).abs() < 2.0,
        "start marked at ({}, {}), wanted ({start_u}, {start_v})",
        m(0),
        m(1)
    );
    ensure!(
        (m(2) - start_heading).abs() < 3.0,
        "heading marked {}°, wanted {start_heading}°",
        m(2)
    );

    // The scale: a line of SCALE_LINE_PX drawing pixels, typed as SCALE_LINE_M meters.
    c.find(Locator::Id("mode-scale")).await?.click().await?;
    drag_on_drawing(c, (150.0, 200.0), (150.0 + SCALE_LINE_PX, 200.0)).await?;
    c.find(Locator::Id("scale-length"))
        .await?
        .send_keys(&SCALE_LINE_M.to_string())
        .await?;
    let request: Value = {
        let text = c
            .execute(
                "return document.getElementById('request-preview').textContent",
                vec![],
            )
            .await?;
        serde_json::from_str(text.as_str().context("request preview")?)?
    };
    let mpp = request["meters_per_pixel"].as_f64().context("m/px sent")?;
    let want = SCALE_LINE_M / SCALE_LINE_PX;
    ensure!(
        (mpp - want).abs() < 0.02 * want,
        "the page would send {mpp} m/px for a {SCALE_LINE_PX} px line of {SCALE_LINE_M} m"
    );
    ensure!(
        request["method"] == "sketch" && request["start"]["u"].as_f64() == Some(m(0)),
        "request shown: {request}"
    );

    c.find(Locator::Id("start-button")).await?.click().await?;
    wait_js(
        c,
        "return !document.getElementById('live').hidden
            && document.getElementById('h-state').textContent",
        Duration::from_secs(10),
        "the live view",
    )
    .await?;

    // The robot drives; the page follows.
    let mut sim = spawn_simulator_lockstep(prefix, "r1", SCANS, None)?;
    wait_js(
        c,
        "const s = Number(document.getElementById('h-scans').textContent);
         const m = document.querySelector('#map-svg g[data-name=robot]');
         const d = document.querySelector('#drawing-svg g[data-name=robot]');
         return s >= 20 && m && d && document.querySelector('#map-svg image')?.getAttribute('href');",
        Duration::from_secs(60),
        "the first scans, map and markers",
    )
    .await?;
    let first = live_state(c).await?;
    wait_js(
        c,
        "return Number(document.getElementById('h-scans').textContent) >= 150",
        Duration::from_secs(120),
        "half the scans",
    )
    .await?;
    full_page_screenshot(c, &shots.join("2-during.png"), 1280).await?;
    // The session was written to disk at its start: the health panel says when.
    let saved = live_saved(c).await?;
    ensure!(saved.starts_with("checkpoint at "), "saved: {saved:?}");

    let status = tokio::task::spawn_blocking(move || {
        let s = sim.wait_timeout(Duration::from_secs(180));
        (sim, s)
    })
    .await?
    .1?;
    ensure!(status.success(), "the simulator failed: {status}");
    wait_js(
        c,
        &format!("return Number(document.getElementById('h-scans').textContent) >= {SCANS}"),
        Duration::from_secs(30),
        "every scan counted on the page",
    )
    .await?;
    // Let the map settle and the page poll it a few times unchanged.
    tokio::time::sleep(Duration::from_secs(4)).await;
    let last = live_state(c).await?;
    ensure!(
        last["scans"].as_f64() > first["scans"].as_f64(),
        "scans did not rise: {first} → {last}"
    );
    ensure!(
        moved(&first["map"], &last["map"]) > 20.0,
        "the robot did not move on the map: {first} → {last}"
    );
    ensure!(
        moved(&first["drawing"], &last["drawing"]) > 20.0,
        "the robot did not move on the drawing: {first} → {last}"
    );
    ensure!(
        last["refreshes"].as_f64() > first["refreshes"].as_f64()
            && last["mapHref"] != first["mapHref"],
        "the map picture did not change: {first} → {last}"
    );
    full_page_screenshot(c, &shots.join("3-after.png"), 1280).await?;
    // The same on a tablet held upright.
    full_page_screenshot(c, &shots.join("4-after-tablet.png"), 820).await?;

    // The unchanged map was revalidated, not resent.
    let metrics = reqwest::Client::new()
        .get(format!("{base}/metrics"))
        .bearer_auth(TOKEN)
        .send()
        .await?
        .text()
        .await?;
    ensure!(
        metrics
            .lines()
            .any(|l| l.contains("route=\"/v1/sessions/{id}/map.png\"")
                && l.contains("status=\"304\"")),
        "no 304 for map.png in /metrics"
    );

    // Stop from the page.
    c.find(Locator::Id("stop-button")).await?.click().await?;
    wait_js(
        c,
        "return document.getElementById('h-state').textContent.startsWith('stopped')",
        Duration::from_secs(30),
        "the session to stop",
    )
    .await?;
    let saved = live_saved(c).await?;
    ensure!(saved.starts_with("stored at its stop"), "saved: {saved:?}");
    Ok(())
}

/// The health panel's "Saved to disk".
async fn live_saved(c: &Client) -> Result<String> {
    let v = c
        .execute(
            "return document.getElementById('h-saved').textContent",
            vec![],
        )
        .await?;
    Ok(v.as_str().unwrap_or_default().to_string())
}
