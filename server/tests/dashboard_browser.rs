//! The dashboard in a real browser: Debian's Chromium driven through chromedriver (WebDriver,
//! with fantoccini) against this build of `sable serve`. A scene with a broken field shows its
//! field paths; a scene submitted through the form appears in the job list and its plots gain
//! points while it runs; it is cancelled from its page; the particle view draws its last
//! snapshot; the studies page shows a study's chart. No page logs an error to the console.
//! Screenshots go to `target/dashboard/` (CI keeps them).
//!
//! Needs `chromium` and `chromedriver` (Debian's `chromium` and `chromium-driver`, which
//! `.ci/run` installs), or `CHROMEDRIVER` and `CHROMIUM` naming them.

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use fantoccini::wd::WebDriverCompatibleCommand;
use fantoccini::{Client, ClientBuilder, Locator};
use serde_json::{json, Value};

fn free_port() -> u16 {
    let l = std::net::TcpListener::bind("127.0.0.1:0").expect("bind");
    l.local_addr().expect("addr").port()
}

/// A child process killed when the test ends, however it ends.
struct Killed(Child);

impl Drop for Killed {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

fn target_dir() -> PathBuf {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).parent().expect("the workspace root").to_path_buf();
    std::env::var_os("CARGO_TARGET_DIR").map(PathBuf::from).unwrap_or_else(|| root.join("target"))
}

/// chromedriver's own command for the browser's console log (not in the W3C protocol).
#[derive(Debug)]
struct BrowserLog;

impl WebDriverCompatibleCommand for BrowserLog {
    fn endpoint(&self, base: &url::Url, session: Option<&str>) -> Result<url::Url, url::ParseError> {
        base.join(&format!("session/{}/se/log", session.unwrap_or_default()))
    }

    fn method_and_body(&self, _: &url::Url) -> (http::Method, Option<String>) {
        (http::Method::POST, Some(json!({"type": "browser"}).to_string()))
    }
}

/// The console messages of level SEVERE since the last call.
async fn console_errors(c: &Client) -> Vec<String> {
    let log = c.issue_cmd(BrowserLog).await.expect("the browser log");
    log.as_array()
        .map(|entries| {
            entries.iter().filter(|e| e["level"] == "SEVERE").map(|e| e["message"].as_str().unwrap_or_default().to_string()).collect()
        })
        .unwrap_or_default()
}

/// Polls `script` (a JavaScript expression) until it is truthy; returns its value.
async fn until(c: &Client, what: &str, script: &str, timeout: Duration) -> Value {
    let start = Instant::now();
    loop {
        let v = c.execute(&format!("return {script};"), vec![]).await.unwrap_or(Value::Null);
        if !(v.is_null() || v == json!(false) || v == json!(0) || v == json!("")) {
            return v;
        }
        if start.elapsed() > timeout {
            let page = c.execute("return [location.href, document.body.innerText.slice(0, 3000), window.__sableErrors];", vec![]).await;
            let log = console_errors(c).await;
            panic!("{what}: not within {timeout:?}; the page: {page:#?}; console errors: {log:#?}");
        }
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
}

async fn screenshot(c: &Client, name: &str) {
    let dir = target_dir().join("dashboard");
    std::fs::create_dir_all(&dir).expect("target/dashboard");
    let png = c.screenshot().await.expect("a screenshot");
    std::fs::write(dir.join(name), png).expect("write the screenshot");
}

fn quickstart(changes: Value) -> Value {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/quickstart.json");
    let mut scene: Value = serde_json::from_str(&std::fs::read_to_string(path).expect("scenes/quickstart.json")).expect("JSON");
    for (k, v) in changes.as_object().expect("an object") {
        scene[k] = v.clone();
    }
    scene
}

/// A browser session on a fresh `sable serve` (one local worker; `extra` flags), with the
/// processes killed when it is dropped.
struct Session {
    c: Client,
    base: String,
    http: reqwest::Client,
    /// The database and the browser's profile, removed at the end.
    _dir: tempfile::TempDir,
    _server: Killed,
    _driver: Killed,
}

async fn session(extra: &[&str]) -> Session {
    let chromedriver = std::env::var("CHROMEDRIVER").unwrap_or_else(|_| "chromedriver".into());
    let chromium = std::env::var("CHROMIUM").unwrap_or_else(|_| "/usr/bin/chromium".into());
    let dir = tempfile::tempdir().expect("temp dir");
    let (http_port, grpc_port, wd_port) = (free_port(), free_port(), free_port());
    let server = Killed(
        Command::new(env!("CARGO_BIN_EXE_sable"))
            .args(["serve", "--workers", "1", "--threads-per-job", "1"])
            .arg("--db")
            .arg(dir.path().join("sable.db"))
            .args(["--http", &format!("127.0.0.1:{http_port}"), "--grpc", &format!("127.0.0.1:{grpc_port}")])
            .args(extra)
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .expect("sable serve starts"),
    );
    let driver = Killed(
        Command::new(&chromedriver)
            .arg(format!("--port={wd_port}"))
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap_or_else(|e| panic!("{chromedriver} does not start ({e}): install chromium and chromium-driver (.ci/run does)")),
    );
    let base = format!("http://127.0.0.1:{http_port}");
    let http = reqwest::Client::new();
    let start = Instant::now();
    while http.get(format!("{base}/healthz")).send().await.is_err()
        || http.get(format!("http://127.0.0.1:{wd_port}/status")).send().await.is_err()
    {
        assert!(start.elapsed() < Duration::from_secs(30), "the server or chromedriver did not answer");
        tokio::time::sleep(Duration::from_millis(100)).await;
    }

    let profile = dir.path().join("chromium");
    let mut caps = serde_json::Map::new();
    caps.insert(
        "goog:chromeOptions".into(),
        json!({"binary": chromium, "args": [
            "--headless=new", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
            "--disable-background-networking", "--disable-component-update", "--disable-sync",
            "--window-size=1300,1900", format!("--user-data-dir={}", profile.display())]}),
    );
    caps.insert("goog:loggingPrefs".into(), json!({"browser": "ALL"}));
    let c = ClientBuilder::new(hyper_util::client::legacy::connect::HttpConnector::new())
        .capabilities(caps)
        .connect(&format!("http://127.0.0.1:{wd_port}"))
        .await
        .expect("a WebDriver session");
    Session { c, base, http, _dir: dir, _server: server, _driver: driver }
}

#[tokio::test]
async fn the_dashboard_submits_watches_cancels_and_draws_a_job_in_a_real_browser() {
    let s = session(&[]).await;
    let (c, base, http) = (&s.c, &s.base, &s.http);
    let wait = Duration::from_secs(60);

    // A rejected scene: every broken field is listed by its path, and nothing is stored.
    c.goto(&format!("{base}/#/submit")).await.expect("the submit page");
    let mut bad = quickstart(json!({}));
    bad["materials"]["glass"]["friction"] = json!(-0.2);
    bad["particles"][0]["count"] = json!(0);
    c.wait().at_most(wait).for_element(Locator::Id("scene-text")).await.expect("the form");
    c.execute("document.getElementById('scene-text').value = arguments[0];", vec![json!(bad.to_string())]).await.expect("fill");
    c.find(Locator::Id("submit")).await.expect("submit button").click().await.expect("click");
    let listed = until(c, "the violations", "document.getElementById('violations')?.innerText", wait).await;
    let listed = listed.as_str().unwrap_or_default();
    assert!(listed.contains("materials.glass.friction") && listed.contains("particles[0].count"), "{listed}");
    let jobs: Value = http.get(format!("{base}/v1/jobs")).send().await.expect("list").json().await.expect("JSON");
    assert_eq!(jobs["jobs"].as_array().map(Vec::len), Some(0), "a rejected scene stored a job");
    // The browser logs the 422 answer itself as an error; it is the only one expected.
    let logged = console_errors(c).await;
    assert!(logged.len() == 1 && logged[0].contains("/v1/jobs") && logged[0].contains("422"), "console errors: {logged:#?}");

    // A valid scene: the advisor's answer, then the job submitted through the form: its page,
    // its plots gaining points while it runs.
    let scene = quickstart(
        json!({"name": "browser", "stop": {"time": 10.0}, "sampling": {"every_steps": 2000}, "snapshots": {"every_steps": 20000}}),
    );
    c.execute("document.getElementById('scene-text').value = arguments[0];", vec![json!(scene.to_string())]).await.expect("fill");
    c.find(Locator::Id("validate")).await.expect("validate button").click().await.expect("click");
    let valid = until(c, "the advisor's answer", "document.getElementById('valid')?.innerText", wait).await;
    assert!(valid.as_str().unwrap_or_default().contains("dem"), "{valid}");
    c.find(Locator::Id("submit")).await.expect("submit button").click().await.expect("click");
    until(c, "the job page", "location.hash.startsWith('#/jobs/')", wait).await;
    let id: i64 = c.execute("return Number(location.hash.split('/')[2]);", vec![]).await.expect("id").as_i64().expect("a job id");
    until(c, "the job running", "document.querySelector('h1 + .toolbar .state-running')", wait).await;
    let first = until(
        c,
        "a first point",
        "Number(document.getElementById('plots')?.dataset.points || 0) >= 2 && Number(document.getElementById('plots').dataset.points)",
        wait,
    )
    .await;
    let first = first.as_i64().unwrap_or_default();
    let more = until(c, "more points while running",
        &format!("document.querySelector('h1 + .toolbar .state-running') && Number(document.getElementById('plots').dataset.points) > {first} + 2 && Number(document.getElementById('plots').dataset.points)"), wait).await;
    assert!(more.as_i64().unwrap_or_default() > first + 2);
    let paths = until(c, "drawn lines", "document.querySelectorAll('#plot-phi canvas').length", wait).await;
    assert!(paths.as_i64().unwrap_or_default() >= 1);
    screenshot(c, "job-running.png").await;

    // The job list shows it, running.
    c.goto(&format!("{base}/#/")).await.expect("the job list");
    let row = until(c, "the job's row", &format!("document.querySelector('tr[data-job=\"{id}\"] .state')?.textContent"), wait).await;
    assert_eq!(row, json!("running"));
    // Its row follows the job's event stream: the sample count grows within 4 s, before the
    // list is read again (every 5 s).
    let cell = format!("Number(document.querySelector('tr[data-job=\"{id}\"] .samples').dataset.n)");
    let before = until(c, "the row's sample count", &cell, wait).await.as_i64().unwrap_or_default();
    until(c, "the row updated live", &format!("{cell} > {before}"), Duration::from_secs(4)).await;
    screenshot(c, "jobs.png").await;

    // Cancelled from its page; the particle view then draws its last snapshot with its contacts.
    c.goto(&format!("{base}/#/jobs/{id}")).await.expect("the job page");
    c.wait().at_most(wait).for_element(Locator::Id("cancel")).await.expect("a cancel button").click().await.expect("cancel");
    until(c, "the job cancelled", "document.querySelector('h1 + .toolbar .state-cancelled')", wait).await;
    let drawn = until(c, "the particles drawn", "Number(document.getElementById('particles')?.dataset.drawn || 0)", wait).await;
    assert_eq!(drawn, json!(250));
    let legend = until(c, "the legend", "document.getElementById('particles-legend')?.innerText", wait).await;
    assert!(legend.as_str().unwrap_or_default().contains("contacts"), "{legend}");
    let painted: Value = c
        .execute(
            "const c = document.getElementById('particles'); const d = c.getContext('2d').getImageData(0, 0, c.width, c.height).data; \
             let n = 0; for (let i = 3; i < d.length; i += 4) if (d[i] > 0) n++; return n / (c.width * c.height);",
            vec![],
        )
        .await
        .expect("the canvas");
    assert!(painted.as_f64().unwrap_or_default() > 0.3, "the canvas is mostly empty: {painted}");
    screenshot(c, "job-cancelled.png").await;

    // A study: its page shows the chart and the runs.
    let study = json!({"name": "browser study", "scene": quickstart(json!({"stop": {"time": 0.01}})),
        "series": [{"label": "DEM", "sweep": [{"parameter": "method.time_step_fraction", "values": [0.02, 0.05]}]}],
        "measure": {"sample": "z"}, "reference": {"finest": "DEM"}});
    let made: Value = http.post(format!("{base}/v1/studies")).json(&study).send().await.expect("study").json().await.expect("JSON");
    let sid = made["id"].as_i64().expect("a study id");
    let start = Instant::now();
    loop {
        let s: Value = http.get(format!("{base}/v1/studies/{sid}")).send().await.expect("study").json().await.expect("JSON");
        if s["state"] != "running" {
            break;
        }
        assert!(start.elapsed() < wait, "the study did not end");
        tokio::time::sleep(Duration::from_millis(200)).await;
    }
    c.goto(&format!("{base}/#/studies")).await.expect("the studies");
    until(c, "the study listed", &format!("document.querySelector('#studies a[href=\"#/studies/{sid}\"]')"), wait).await;
    c.goto(&format!("{base}/#/studies/{sid}")).await.expect("the study");
    until(c, "the chart loaded", "document.querySelector('img.chart')?.complete && document.querySelector('img.chart').naturalWidth", wait)
        .await;
    let runs = until(c, "the runs", "document.querySelectorAll('#runs tbody tr').length", wait).await;
    assert_eq!(runs, json!(2));

    // Keyboard: from the top of a page, Tab reaches the skip link, then the sections' links;
    // the skip link moves the focus to the content and leaves the page where it is.
    let mut page_errors = vec![c.execute("return window.__sableErrors;", vec![]).await.expect("the page's errors")];
    c.goto(&format!("{base}/?keyboard#/studies")).await.expect("the studies, loaded anew");
    until(c, "the studies", "document.getElementById('studies')", wait).await;
    let body = c.find(Locator::Css("body")).await.expect("body");
    let mut reached = Vec::new();
    for _ in 0..4 {
        body.send_keys("\u{E004}").await.expect("Tab");
        reached.push(c.execute("return document.activeElement.textContent.trim();", vec![]).await.expect("focus"));
    }
    assert_eq!(reached, vec![json!("Skip to content"), json!("Sable"), json!("Jobs"), json!("Studies")]);
    c.execute("document.querySelector('.skip').focus();", vec![]).await.expect("focus the skip link");
    c.find(Locator::Css(".skip")).await.expect("skip link").send_keys("\u{E007}").await.expect("Enter");
    let after: Value = c.execute("return [document.activeElement.id, location.hash];", vec![]).await.expect("focus");
    assert_eq!(after, json!(["main", "#/studies"]));

    let errors = console_errors(c).await;
    page_errors.push(c.execute("return window.__sableErrors;", vec![]).await.expect("the page's errors"));
    c.clone().close().await.expect("close the browser");
    assert!(errors.is_empty(), "console errors: {errors:#?}");
    assert_eq!(page_errors, vec![json!([]), json!([])], "errors the pages caught (before and after the reload)");
}

/// On a server that needs users' tokens the dashboard asks for one, keeps it, and sends it with
/// its calls, its event streams (the query's access_token) and its chart images: the job list
/// loads and a job's plots gain points from its event stream.
#[tokio::test]
async fn the_dashboard_asks_for_a_token_and_uses_it_everywhere() {
    let tokens = tempfile::tempdir().expect("dir");
    let (user, worker) = ("browser-user-token-0123456789", "browser-worker-token-0123456789");
    std::fs::write(tokens.path().join("users"), format!("{user}\n")).expect("write");
    std::fs::write(tokens.path().join("workers"), format!("{worker}\n")).expect("write");
    let users = tokens.path().join("users").display().to_string();
    let workers = tokens.path().join("workers").display().to_string();
    let s = session(&["--user-tokens", &users, "--worker-tokens", &workers]).await;
    let (c, base, http) = (&s.c, &s.base, &s.http);
    let wait = Duration::from_secs(60);
    let job: Value = http
        .post(format!("{base}/v1/jobs"))
        .bearer_auth(user)
        .json(&quickstart(json!({"name": "tokens", "stop": {"time": 10.0}, "sampling": {"every_steps": 2000}})))
        .send()
        .await
        .expect("submit")
        .json()
        .await
        .expect("JSON");
    let id = job["id"].as_i64().expect("a job id");

    // The first call is refused: the page asks; a worker's token is refused again (403), the
    // user's is kept.
    c.goto(&format!("{base}/#/")).await.expect("the job list");
    let start = Instant::now();
    let mut asked = Vec::new();
    for token in [worker, user] {
        loop {
            if let Ok(text) = c.get_alert_text().await {
                asked.push(text);
                c.send_alert_text(token).await.expect("type the token");
                c.accept_alert().await.expect("accept");
                break;
            }
            assert!(start.elapsed() < wait, "the dashboard did not ask for a token");
            tokio::time::sleep(Duration::from_millis(100)).await;
        }
        if token == worker {
            // The list is read again after the refusal (every 5 s).
            c.refresh().await.ok();
        }
    }
    assert!(asked.iter().all(|t| t.contains("user's token")), "{asked:?}");
    let row = until(c, "the job's row", &format!("document.querySelector('tr[data-job=\"{id}\"] .state')?.textContent"), wait).await;
    assert!(row == json!("running") || row == json!("queued"), "{row}");
    let kept: Value = c.execute("return localStorage.getItem('sable.token');", vec![]).await.expect("storage");
    assert_eq!(kept, json!(user));
    // The job's page: its plots gain points from the event stream, which carries the token.
    c.goto(&format!("{base}/#/jobs/{id}")).await.expect("the job page");
    let points =
        "Number(document.getElementById('plots')?.dataset.points || 0) >= 2 && Number(document.getElementById('plots').dataset.points)";
    let first = until(c, "the first points", points, wait).await.as_i64().unwrap_or_default();
    let more = format!(
        "Number(document.getElementById('plots').dataset.points) > {first} + 2 && Number(document.getElementById('plots').dataset.points)"
    );
    until(c, "more points from the event stream", &more, wait).await;
    c.clone().close().await.expect("close the browser");
}
