//! A headless Chromium driven over the DevTools protocol (a WebSocket, JSON): open a
//! page, evaluate script in it, take screenshots, and collect every JavaScript error it
//! throws or logs. Debian's `chromium`; [`Browser::start`] is `None` where it is missing.

use std::io::{BufRead, BufReader};
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::Duration;

use futures_util::{SinkExt, StreamExt};
use serde_json::{json, Value};
use tokio_tungstenite::tungstenite::Message;

type Socket = tokio_tungstenite::WebSocketStream<tokio_tungstenite::MaybeTlsStream<tokio::net::TcpStream>>;

/// A browser with one page attached.
pub struct Browser {
    child: Child,
    ws: Socket,
    session: String,
    next: u64,
    /// JavaScript errors seen: exceptions, `console.error`, error log entries.
    pub errors: Vec<String>,
    _profile: tempfile::TempDir,
}

impl Drop for Browser {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

fn chromium() -> Option<String> {
    ["chromium", "chromium-browser"].iter().find_map(|c| {
        let out = Command::new("sh").args(["-c", &format!("command -v {c}")]).output().ok()?;
        out.status.success().then(|| String::from_utf8_lossy(&out.stdout).trim().to_string())
    })
}

impl Browser {
    /// Starts headless Chromium (software WebGL) on a fresh profile, with one blank page.
    pub async fn start() -> Option<Self> {
        let bin = chromium()?;
        let profile = tempfile::tempdir().unwrap();
        let mut child = Command::new(bin)
            .args([
                "--headless",
                "--no-sandbox",
                "--disable-gpu",
                "--use-angle=swiftshader",
                "--enable-unsafe-swiftshader",
                "--no-first-run",
                "--disable-background-networking",
                "--disable-component-update",
                "--disable-sync",
                "--window-size=1600,1000",
                "--remote-debugging-port=0",
            ])
            .arg(format!("--user-data-dir={}", profile.path().display()))
            .arg("about:blank")
            .stderr(Stdio::piped())
            .stdout(Stdio::null())
            .spawn()
            .expect("chromium starts");
        let mut lines = BufReader::new(child.stderr.take().unwrap()).lines();
        let url = lines
            .by_ref()
            .map_while(Result::ok)
            .find_map(|l| l.split("DevTools listening on ").nth(1).map(str::to_string))
            .expect("chromium prints its DevTools address");
        std::thread::spawn(move || for _ in lines {});
        let (ws, _) = tokio_tungstenite::connect_async(url.trim()).await.expect("DevTools connects");
        let mut b = Self { child, ws, session: String::new(), next: 0, errors: Vec::new(), _profile: profile };
        let target = b.call("Target.createTarget", json!({"url": "about:blank"})).await;
        let attached = b.call("Target.attachToTarget", json!({"targetId": target["targetId"], "flatten": true})).await;
        b.session = attached["sessionId"].as_str().expect("a session").to_string();
        for domain in ["Runtime.enable", "Page.enable", "Log.enable"] {
            b.call(domain, json!({})).await;
        }
        Some(b)
    }

    /// Sends `method` (to the page once attached) and waits for its result, keeping the
    /// errors among the events that arrive meanwhile.
    pub async fn call(&mut self, method: &str, params: Value) -> Value {
        self.next += 1;
        let id = self.next;
        let mut msg = json!({"id": id, "method": method, "params": params});
        if !self.session.is_empty() {
            msg["sessionId"] = json!(self.session);
        }
        self.ws.send(Message::Text(msg.to_string().into())).await.unwrap();
        // One deadline for the answer, however many events arrive before it.
        let deadline = tokio::time::Instant::now() + Duration::from_secs(60);
        loop {
            let m = tokio::time::timeout_at(deadline, self.ws.next())
                .await
                .unwrap_or_else(|_| panic!("{method}: no answer in 60 s"))
                .expect("DevTools open")
                .unwrap();
            let Message::Text(t) = m else { continue };
            let v: Value = serde_json::from_str(&t).unwrap();
            if v["id"] == id {
                assert!(v.get("error").is_none(), "{method}: {v}");
                return v["result"].clone();
            }
            self.keep_error(&v);
        }
    }

    fn keep_error(&mut self, v: &Value) {
        let p = &v["params"];
        match v["method"].as_str() {
            Some("Runtime.exceptionThrown") => self.errors.push(p["exceptionDetails"].to_string()),
            Some("Runtime.consoleAPICalled") if p["type"] == "error" => self.errors.push(p["args"].to_string()),
            // The network stack's own complaints (a favicon) are not the page's.
            Some("Log.entryAdded") if p["entry"]["level"] == "error" && p["entry"]["source"] != "network" => {
                self.errors.push(p["entry"].to_string());
            }
            _ => {}
        }
    }

    /// Opens `url`.
    pub async fn open(&mut self, url: &str) {
        self.call("Page.navigate", json!({"url": url})).await;
    }

    /// The value of the expression `js` in the page (returned by value).
    pub async fn eval(&mut self, js: &str) -> Value {
        let r = self.call("Runtime.evaluate", json!({"expression": js, "returnByValue": true})).await;
        assert!(r.get("exceptionDetails").is_none(), "{js}: {r}");
        r["result"]["value"].clone()
    }

    /// Evaluates `js` every 50 ms until it is true; false after `seconds`. An expression
    /// that throws (the page still loading: no `document.body` yet) counts as false.
    pub async fn wait_for(&mut self, js: &str, seconds: f64) -> bool {
        let end = std::time::Instant::now() + Duration::from_secs_f64(seconds);
        let guarded = format!("(() => {{ try {{ return ({js}) === true; }} catch (e) {{ return false; }} }})()");
        while std::time::Instant::now() < end {
            if self.eval(&guarded).await == json!(true) {
                return true;
            }
            tokio::time::sleep(Duration::from_millis(50)).await;
        }
        false
    }

    /// A PNG of the page, written to `path`.
    pub async fn screenshot(&mut self, path: &Path) -> Vec<u8> {
        let r = self.call("Page.captureScreenshot", json!({"format": "png"})).await;
        let png = base64::Engine::decode(&base64::engine::general_purpose::STANDARD, r["data"].as_str().unwrap())
            .expect("a base64 screenshot");
        std::fs::write(path, &png).unwrap();
        png
    }
}
