//! A headless Chromium for the tests of the HTML report, driven over the Chrome DevTools Protocol
//! (CDP) through `--remote-debugging-pipe`: Chromium reads commands on its fd 3 and writes replies
//! and events on its fd 4, each message one JSON text ended by a NUL byte. A pipe needs no port,
//! no HTTP and no websocket, and Chromium quits by itself when the test process dies (its end of
//! the pipe closes), so no browser outlives a killed test run.
//!
//! One page target is attached (flat session) with `Page`, `Runtime`, `Network` and `Log` enabled
//! before any navigation. Every event is handled as it arrives, also while a command waits for its
//! reply, so nothing that goes wrong is missed: see [`Browser::problems`]. Every command has a
//! timeout ([`Browser::set_timeout`], 30 s by default); a hang is an `Err` naming the CDP method.
//! Dropping the [`Browser`] kills Chromium's whole process group and its crash handlers (which
//! run in sessions of their own), reaps them all and removes the profile directory, also when the
//! test panics. To reap them, the first launch makes the test process the subreaper of its
//! descendants (`PR_SET_CHILD_SUBREAPER`), and `XDG_CONFIG_HOME` points into the profile, so that
//! the crash handlers' command lines name it (and nothing is written to the home directory).

use serde_json::{json, Value};
use std::collections::HashMap;
use std::io::{BufRead, BufReader, Write};
use std::os::fd::AsRawFd;
use std::os::unix::process::CommandExt;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::mpsc::{Receiver, RecvTimeoutError};
use std::time::{Duration, Instant};

/// The timeout of one command, unless [`Browser::set_timeout`] says otherwise.
pub const DEFAULT_TIMEOUT: Duration = Duration::from_secs(30);

/// A headless Chromium with one page, driven over CDP; see the module documentation.
pub struct Browser {
    child: Child,
    to_chrome: std::io::PipeWriter,
    from_chrome: Receiver<Value>,
    session: String,
    next_id: u64,
    timeout: Duration,
    problems: Vec<String>,
    requests: HashMap<String, String>,
    loaded: bool,
    modifiers: u32,
    buttons: u32,
    // The pids of Chromium's crash handlers: outside its process group, in sessions of their own.
    helpers: Vec<u32>,
    // Last field: removed after Drop::drop has killed Chromium.
    profile: tempfile::TempDir,
}

impl Browser {
    /// Starts headless Chromium with a 1280 × 800 viewport: the program in the environment
    /// variable `CHROMIUM`, else `/usr/bin/chromium`, else `chromium` on the `PATH`. No browser
    /// is an `Err` saying what was tried.
    pub fn launch() -> Result<Browser, String> {
        Browser::launch_with_size(1280, 800)
    }

    /// [`Browser::launch`] with a viewport of `width` × `height` CSS pixels (device scale 1).
    pub fn launch_with_size(width: u32, height: u32) -> Result<Browser, String> {
        Browser::launch_program(&find_chromium()?, width, height)
    }

    /// Starts the Chromium at `program` headless, with a fresh profile and a viewport of
    /// `width` × `height` CSS pixels, and attaches to its page.
    pub fn launch_program(program: &Path, width: u32, height: u32) -> Result<Browser, String> {
        subreaper();
        let profile = tempfile::Builder::new()
            .prefix("vitrum-chromium-")
            .tempdir()
            .map_err(|e| format!("chromium profile directory: {e}"))?;
        let (to_chrome_read, to_chrome) = std::io::pipe().map_err(|e| format!("pipe: {e}"))?;
        let (from_chrome, from_chrome_write) = std::io::pipe().map_err(|e| format!("pipe: {e}"))?;
        let stderr = std::fs::File::create(profile.path().join("stderr.txt"))
            .map_err(|e| format!("chromium stderr file: {e}"))?;
        let mut command = Command::new(program);
        command
            .args([
                "--headless",
                "--no-sandbox",
                "--disable-gpu",
                "--disable-quic",
                "--no-first-run",
                "--disable-background-networking",
                "--disable-component-update",
                "--disable-sync",
                "--disable-extensions",
                "--no-default-browser-check",
                "--hide-scrollbars",
                "--mute-audio",
                "--remote-debugging-pipe",
            ])
            .arg(format!("--user-data-dir={}", profile.path().display()))
            .arg(format!("--window-size={width},{height}"))
            .arg("about:blank")
            // Chromium's crash handler keeps its database in $XDG_CONFIG_HOME/chromium: inside
            // the profile, nothing is written to the home directory, and the handler's command
            // line names the profile, so that Drop finds it.
            .env("XDG_CONFIG_HOME", profile.path())
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(stderr)
            .process_group(0);
        let (read_fd, write_fd) = (to_chrome_read.as_raw_fd(), from_chrome_write.as_raw_fd());
        // SAFETY: between fork and exec only async-signal-safe calls (fcntl, dup2). Both ends are
        // first copied above fd 10 (closed at exec), so that neither dup2 overwrites the other.
        unsafe {
            command.pre_exec(move || {
                let a = libc::fcntl(read_fd, libc::F_DUPFD_CLOEXEC, 10);
                let b = libc::fcntl(write_fd, libc::F_DUPFD_CLOEXEC, 10);
                if a < 0 || b < 0 || libc::dup2(a, 3) < 0 || libc::dup2(b, 4) < 0 {
                    return Err(std::io::Error::last_os_error());
                }
                Ok(())
            });
        }
        let child = command.spawn().map_err(|e| format!("cannot start {}: {e}", program.display()))?;
        // Chromium holds these ends now; ours must close, or the reader never sees Chromium go.
        drop((to_chrome_read, from_chrome_write));
        let (sender, receiver) = std::sync::mpsc::channel();
        std::thread::spawn(move || {
            let mut reader = BufReader::new(from_chrome);
            let mut message = Vec::new();
            while matches!(reader.read_until(0, &mut message), Ok(n) if n > 0) {
                if message.last() == Some(&0) {
                    message.pop();
                }
                if let Ok(value) = serde_json::from_slice::<Value>(&message) {
                    if sender.send(value).is_err() {
                        break;
                    }
                }
                message.clear();
            }
        });
        let mut browser = Browser {
            child,
            to_chrome,
            from_chrome: receiver,
            session: String::new(),
            next_id: 0,
            timeout: DEFAULT_TIMEOUT,
            problems: Vec::new(),
            requests: HashMap::new(),
            loaded: false,
            modifiers: 0,
            buttons: 0,
            helpers: Vec::new(),
            profile,
        };
        browser.attach(width, height).map_err(|e| format!("{e}{}", browser.stderr_tail()))?;
        // The crash handlers started by now; they are reaped on drop even if they die first.
        let group = browser.child.id();
        browser.helpers =
            naming(browser.profile.path()).into_iter().filter(|h| h.1 != group).map(|h| h.0).collect();
        Ok(browser)
    }

    /// Attaches to the first page target (one is made if there is none), enables the domains
    /// whose events are watched and sets the viewport.
    fn attach(&mut self, width: u32, height: u32) -> Result<(), String> {
        let targets = self.call_browser("Target.getTargets", json!({}))?;
        let page = targets["targetInfos"]
            .as_array()
            .and_then(|t| t.iter().find(|t| t["type"] == "page"))
            .and_then(|t| t["targetId"].as_str().map(str::to_owned));
        let target = match page {
            Some(id) => id,
            None => self.call_browser("Target.createTarget", json!({"url": "about:blank"}))?["targetId"]
                .as_str()
                .ok_or("Target.createTarget: no targetId")?
                .to_owned(),
        };
        let attached =
            self.call_browser("Target.attachToTarget", json!({"targetId": target, "flatten": true}))?;
        self.session =
            attached["sessionId"].as_str().ok_or("Target.attachToTarget: no sessionId")?.to_owned();
        for domain in ["Page", "Runtime", "Network", "Log"] {
            self.call(&format!("{domain}.enable"), json!({}))?;
        }
        self.call("Emulation.setFocusEmulationEnabled", json!({"enabled": true}))?;
        self.set_viewport(width, height)
    }

    /// Sets the timeout of each later command (and of a page load).
    pub fn set_timeout(&mut self, timeout: Duration) {
        self.timeout = timeout;
    }

    /// The process id of Chromium, which leads its process group.
    pub fn pid(&self) -> u32 {
        self.child.id()
    }

    /// The profile directory (`--user-data-dir`), removed on drop.
    pub fn profile_dir(&self) -> &Path {
        self.profile.path()
    }

    /// Makes the viewport `width` × `height` CSS pixels at a device scale factor of 1
    /// (`Emulation.setDeviceMetricsOverride`).
    pub fn set_viewport(&mut self, width: u32, height: u32) -> Result<(), String> {
        let metrics = json!({"width": width, "height": height, "deviceScaleFactor": 1, "mobile": false});
        self.call("Emulation.setDeviceMetricsOverride", metrics).map(drop)
    }

    /// Opens the file at the absolute `path` (as a `file://` URL) and waits for its load event
    /// (`Page.loadEventFired`); returns the time from the navigation command to the load event.
    /// A missing file is an `Err`.
    pub fn open(&mut self, path: &Path) -> Result<Duration, String> {
        if !path.is_absolute() {
            return Err(format!("open: {} is not an absolute path", path.display()));
        }
        let url = file_url(path);
        let start = Instant::now();
        self.loaded = false;
        let reply = self.call("Page.navigate", json!({"url": url}))?;
        if let Some(error) = reply["errorText"].as_str() {
            return Err(format!("open {url}: {error}"));
        }
        if reply.get("loaderId").is_none() {
            return Ok(start.elapsed()); // a same-document navigation has no load event
        }
        let deadline = start + self.timeout;
        while !self.loaded {
            let message = self.next_message(deadline, start, "Page.loadEventFired")?;
            self.handle(message);
        }
        Ok(start.elapsed())
    }

    /// Evaluates `js` in the page (`Runtime.evaluate`, awaiting a promise) and returns its value
    /// as JSON (`null` for `undefined`); a thrown exception is an `Err` with its text.
    pub fn eval(&mut self, js: &str) -> Result<Value, String> {
        let deadline = Instant::now() + self.timeout;
        self.eval_until(js, deadline)
    }

    fn eval_until(&mut self, js: &str, deadline: Instant) -> Result<Value, String> {
        let params =
            json!({"expression": js, "returnByValue": true, "awaitPromise": true, "userGesture": true});
        let mut reply = self.call_until("Runtime.evaluate", params, true, deadline)?;
        if let Some(details) = reply.get("exceptionDetails") {
            return Err(format!("eval {js:?}: {}", exception_text(details)));
        }
        Ok(reply["result"]["value"].take())
    }

    /// Polls the JS expression `js_condition` (every 20 ms) until it is truthy; an `Err` after
    /// `timeout`, with the last exception the condition threw, if any.
    pub fn wait_until(&mut self, js_condition: &str, timeout: Duration) -> Result<(), String> {
        let deadline = Instant::now() + timeout;
        let js = format!("!!(\n{js_condition}\n)");
        let mut last_error = String::new();
        loop {
            match self.eval_until(&js, deadline) {
                Ok(Value::Bool(true)) => return Ok(()),
                Ok(_) => {}
                Err(e) => last_error = format!(" (last: {e})"),
            }
            if Instant::now() >= deadline {
                return Err(format!(
                    "wait_until {js_condition:?}: still false after {timeout:?}{last_error}"
                ));
            }
            std::thread::sleep(Duration::from_millis(20));
        }
    }

    /// Presses `key` (`Input.dispatchKeyEvent`, keyDown): a digit, a letter (upper case while
    /// Shift is held), a US-keyboard symbol such as `+ - [ ]`, or a named key (`Shift`, `Control`,
    /// `Alt`, `Meta`, `Enter`, `Tab`, `Escape`, `Backspace`, `Delete`, `Space`, `Home`, `End`,
    /// `PageUp`, `PageDown`, `ArrowLeft`/`Right`/`Up`/`Down`, `F1`…`F12`). The page's `keydown`
    /// sees it as `event.key`, with a matching `event.code` and `keyCode`.
    pub fn key_down(&mut self, key: &str) -> Result<(), String> {
        let info = key_info(key, self.modifiers & SHIFT != 0)?;
        self.modifiers |= info.modifier;
        let kind = if info.text.is_empty() { "rawKeyDown" } else { "keyDown" };
        self.key_event(kind, &info)
    }

    /// Releases `key` (keyUp); see [`Browser::key_down`].
    pub fn key_up(&mut self, key: &str) -> Result<(), String> {
        let info = key_info(key, self.modifiers & SHIFT != 0)?;
        self.modifiers &= !info.modifier;
        self.key_event("keyUp", &info)
    }

    /// Presses and releases `key`; see [`Browser::key_down`].
    pub fn press(&mut self, key: &str) -> Result<(), String> {
        self.key_down(key)?;
        self.key_up(key)
    }

    fn key_event(&mut self, kind: &str, info: &KeyInfo) -> Result<(), String> {
        let mut params = json!({
            "type": kind,
            "modifiers": self.modifiers,
            "key": info.key,
            "code": info.code,
            "windowsVirtualKeyCode": info.key_code,
            "nativeVirtualKeyCode": info.key_code,
            "location": info.location,
        });
        if kind == "keyDown" {
            params["text"] = json!(info.text);
            params["unmodifiedText"] = json!(info.text);
        }
        self.call("Input.dispatchKeyEvent", params).map(drop)
    }

    /// Moves the mouse to (`x`, `y`) in CSS pixels of the viewport (`Input.dispatchMouseEvent`).
    pub fn mouse_move(&mut self, x: f64, y: f64) -> Result<(), String> {
        let button = if self.buttons & 1 != 0 { "left" } else { "none" };
        self.mouse_event("mouseMoved", x, y, button, json!({}))
    }

    /// Turns the mouse wheel by `dy` CSS pixels (positive: down) at (`x`, `y`).
    pub fn mouse_wheel(&mut self, x: f64, y: f64, dy: f64) -> Result<(), String> {
        self.mouse_event("mouseWheel", x, y, "none", json!({"deltaX": 0, "deltaY": dy}))
    }

    /// Clicks the left button at (`x`, `y`).
    pub fn click(&mut self, x: f64, y: f64) -> Result<(), String> {
        self.mouse_move(x, y)?;
        self.button("mousePressed", x, y)?;
        self.button("mouseReleased", x, y)
    }

    /// Drags with the left button from `from` to `to` (press, ten moves, release).
    pub fn drag(&mut self, from: (f64, f64), to: (f64, f64)) -> Result<(), String> {
        self.mouse_move(from.0, from.1)?;
        self.button("mousePressed", from.0, from.1)?;
        for i in 1..=10 {
            let t = i as f64 / 10.0;
            self.mouse_move(from.0 + (to.0 - from.0) * t, from.1 + (to.1 - from.1) * t)?;
        }
        self.button("mouseReleased", to.0, to.1)
    }

    fn button(&mut self, kind: &str, x: f64, y: f64) -> Result<(), String> {
        if kind == "mousePressed" {
            self.buttons |= 1;
        } else {
            self.buttons &= !1;
        }
        self.mouse_event(kind, x, y, "left", json!({"clickCount": 1}))
    }

    fn mouse_event(&mut self, kind: &str, x: f64, y: f64, button: &str, extra: Value) -> Result<(), String> {
        let mut params = json!({
            "type": kind, "x": x, "y": y, "button": button,
            "buttons": self.buttons, "modifiers": self.modifiers,
        });
        if let (Some(p), Value::Object(extra)) = (params.as_object_mut(), extra) {
            p.extend(extra);
        }
        self.call("Input.dispatchMouseEvent", params).map(drop)
    }

    /// Writes a PNG of the viewport to `path` (`Page.captureScreenshot`).
    pub fn screenshot(&mut self, path: &Path) -> Result<(), String> {
        self.capture(path, json!({"format": "png"}))
    }

    /// Writes a PNG of the page's rectangle at (`x`, `y`) of `width` × `height` CSS pixels to
    /// `path`, also where it lies beyond the viewport.
    pub fn screenshot_clip(
        &mut self,
        path: &Path,
        x: f64,
        y: f64,
        width: f64,
        height: f64,
    ) -> Result<(), String> {
        let clip = json!({"x": x, "y": y, "width": width, "height": height, "scale": 1});
        self.capture(path, json!({"format": "png", "clip": clip, "captureBeyondViewport": true}))
    }

    fn capture(&mut self, path: &Path, params: Value) -> Result<(), String> {
        let reply = self.call("Page.captureScreenshot", params)?;
        let data = reply["data"].as_str().ok_or("Page.captureScreenshot: no data")?;
        let png = base64_decode(data).ok_or("Page.captureScreenshot: bad base64")?;
        std::fs::write(path, png).map_err(|e| format!("screenshot {}: {e}", path.display()))
    }

    /// Everything that went wrong since the launch (or [`Browser::clear_problems`]), one line
    /// each: console errors, warnings and failed asserts (`Runtime.consoleAPICalled`), uncaught
    /// exceptions (`Runtime.exceptionThrown`), failed requests (`Network.loadingFailed`, HTTP
    /// status ≥ 400), browser log errors (`Log.entryAdded`, e.g. "Failed to load resource" of a
    /// missing file), dialogs (accepted at once) and a crashed page. A missing local file (a
    /// `<script src>`, an image) shows twice: as `Network.loadingFailed` and as its log entry.
    pub fn problems(&mut self) -> Vec<String> {
        while let Ok(message) = self.from_chrome.try_recv() {
            self.handle(message);
        }
        self.problems.clone()
    }

    /// Forgets the problems seen so far (those still in the pipe as well).
    pub fn clear_problems(&mut self) {
        self.problems();
        self.problems.clear();
    }

    /// Records what an event says; replies to timed-out commands are dropped here.
    fn handle(&mut self, message: Value) {
        let (Some(method), Some(session)) = (message["method"].as_str(), message["sessionId"].as_str())
        else {
            return;
        };
        if session != self.session {
            return;
        }
        let p = &message["params"];
        let text = |v: &Value| v.as_str().unwrap_or("").to_owned();
        match method {
            "Page.loadEventFired" => self.loaded = true,
            "Runtime.consoleAPICalled"
                if matches!(p["type"].as_str(), Some("error" | "warning" | "assert")) =>
            {
                let args: Vec<String> = p["args"].as_array().into_iter().flatten().map(remote_text).collect();
                let frame = &p["stackTrace"]["callFrames"][0];
                let at = location(&frame["url"], &frame["lineNumber"]);
                self.problems.push(format!("console.{}: {}{at}", text(&p["type"]), args.join(" ")));
            }
            "Runtime.exceptionThrown" => {
                let details = &p["exceptionDetails"];
                let at = location(&details["url"], &details["lineNumber"]);
                self.problems.push(format!("exception: {}{at}", exception_text(details)));
            }
            "Network.requestWillBeSent" => {
                self.requests.insert(text(&p["requestId"]), text(&p["request"]["url"]));
            }
            "Network.responseReceived" if p["response"]["status"].as_f64().is_some_and(|s| s >= 400.0) => {
                let status = &p["response"]["status"];
                self.problems.push(format!("request failed: HTTP {status} {}", text(&p["response"]["url"])));
            }
            "Network.loadingFailed" if p["canceled"] != true => {
                let url =
                    self.requests.get(p["requestId"].as_str().unwrap_or("")).cloned().unwrap_or_default();
                self.problems.push(format!("request failed: {} {url}", text(&p["errorText"])));
            }
            "Log.entryAdded" if p["entry"]["level"] == "error" => {
                let e = &p["entry"];
                self.problems.push(format!(
                    "log ({}): {} {}",
                    text(&e["source"]),
                    text(&e["text"]),
                    text(&e["url"])
                ));
            }
            "Page.javascriptDialogOpening" => {
                self.problems.push(format!("dialog ({}): {}", text(&p["type"]), text(&p["message"])));
                // Not awaited: the reply, whenever it comes, is dropped by `handle`.
                let _ = self.send("Page.handleJavaScriptDialog", json!({"accept": true}), true);
            }
            "Inspector.targetCrashed" => self.problems.push("the page crashed".to_owned()),
            _ => {}
        }
    }

    /// Sends a command to the page's session, or to the browser if `page` is false; its id.
    fn send(&mut self, method: &str, params: Value, page: bool) -> Result<u64, String> {
        self.next_id += 1;
        let mut message = json!({"id": self.next_id, "method": method, "params": params});
        if page {
            message["sessionId"] = json!(self.session);
        }
        let mut bytes = serde_json::to_vec(&message).map_err(|e| format!("CDP {method}: {e}"))?;
        bytes.push(0);
        self.to_chrome.write_all(&bytes).map_err(|e| format!("CDP {method}: chromium is gone ({e})"))?;
        Ok(self.next_id)
    }

    fn call(&mut self, method: &str, params: Value) -> Result<Value, String> {
        let deadline = Instant::now() + self.timeout;
        self.call_until(method, params, true, deadline)
    }

    fn call_browser(&mut self, method: &str, params: Value) -> Result<Value, String> {
        let deadline = Instant::now() + self.timeout;
        self.call_until(method, params, false, deadline)
    }

    /// Sends a command and waits for its reply until `deadline`, handling the events meanwhile.
    fn call_until(
        &mut self,
        method: &str,
        params: Value,
        page: bool,
        deadline: Instant,
    ) -> Result<Value, String> {
        let (id, sent) = (self.send(method, params, page)?, Instant::now());
        loop {
            let mut message = self.next_message(deadline, sent, method)?;
            if message["id"].as_u64() == Some(id) {
                if let Some(error) = message.get("error") {
                    return Err(format!("CDP {method}: {}", error["message"].as_str().unwrap_or("error")));
                }
                return Ok(message["result"].take());
            }
            self.handle(message);
        }
    }

    /// The next message from Chromium, waiting until `deadline` for it (`since`: when the wait
    /// for `what` began, for the error).
    fn next_message(&mut self, deadline: Instant, since: Instant, what: &str) -> Result<Value, String> {
        let wait = deadline.saturating_duration_since(Instant::now());
        match self.from_chrome.recv_timeout(wait) {
            Ok(message) => Ok(message),
            Err(RecvTimeoutError::Timeout) => {
                Err(format!("CDP {what}: no reply after {:.1} s", since.elapsed().as_secs_f64()))
            }
            Err(RecvTimeoutError::Disconnected) => {
                let status = self.child.try_wait().ok().flatten();
                Err(format!("CDP {what}: chromium closed the pipe (exit status {status:?})"))
            }
        }
    }

    /// The end of Chromium's stderr, for a failed launch.
    fn stderr_tail(&self) -> String {
        let text = std::fs::read_to_string(self.profile.path().join("stderr.txt")).unwrap_or_default();
        let lines: Vec<&str> = text.lines().collect();
        format!("\nchromium's stderr ends:\n{}", lines[lines.len().saturating_sub(20)..].join("\n"))
    }
}

impl Drop for Browser {
    /// Kills Chromium's process group and its crash handlers, and reaps them all (the test
    /// process is their subreaper); the profile is removed afterwards.
    fn drop(&mut self) {
        let group = self.child.id() as libc::pid_t;
        // SAFETY: kill and waitpid have no memory effects. The group is the one spawned with
        // process_group(0); waitpid(-group) reaps only its members. A helper is killed only while
        // its command line names the profile, and waited for only while we are its subreaper:
        // then its pid stays its own until it is reaped here.
        unsafe { libc::kill(-group, libc::SIGKILL) };
        let _ = self.child.wait();
        let mut helpers = std::mem::take(&mut self.helpers);
        helpers.extend(naming(self.profile.path()).into_iter().filter(|h| h.1 != group as u32).map(|h| h.0));
        if !subreaper() {
            helpers.clear();
        }
        let deadline = Instant::now() + Duration::from_secs(10);
        let mut group_left = true;
        while (group_left || !helpers.is_empty()) && Instant::now() < deadline {
            let alive = naming(self.profile.path());
            for pid in &helpers {
                if alive.iter().any(|h| h.0 == *pid) {
                    unsafe { libc::kill(*pid as libc::pid_t, libc::SIGKILL) };
                }
            }
            while group_left {
                match unsafe { libc::waitpid(-group, std::ptr::null_mut(), libc::WNOHANG) } {
                    0 => break,
                    r if r > 0 => {}
                    _ if std::io::Error::last_os_error().raw_os_error() == Some(libc::EINTR) => {}
                    _ => group_left = false, // ECHILD: none left
                }
            }
            helpers.retain(
                |&pid| unsafe { libc::waitpid(pid as libc::pid_t, std::ptr::null_mut(), libc::WNOHANG) } == 0,
            );
            if group_left || !helpers.is_empty() {
                unsafe { libc::kill(-group, libc::SIGKILL) };
                std::thread::sleep(Duration::from_millis(5));
            }
        }
    }
}

/// Makes this process the subreaper of its descendants (once), so that Chromium's processes
/// which outlive their parent are reaped by Drop rather than left as zombies to an init that may
/// be slow to reap them; whether that worked.
fn subreaper() -> bool {
    static DONE: std::sync::OnceLock<bool> = std::sync::OnceLock::new();
    // SAFETY: prctl(PR_SET_CHILD_SUBREAPER) only sets a flag of this process.
    *DONE.get_or_init(|| unsafe { libc::prctl(libc::PR_SET_CHILD_SUBREAPER, 1) } == 0)
}

/// The live processes whose command line names `dir` (all of Chromium's do, for its profile),
/// as (pid, process group).
fn naming(dir: &Path) -> Vec<(u32, u32)> {
    use std::os::unix::ffi::OsStrExt;
    let needle = dir.as_os_str().as_bytes();
    let Ok(entries) = std::fs::read_dir("/proc") else { return Vec::new() };
    let mut found = Vec::new();
    for entry in entries.flatten() {
        let Some(pid) = entry.file_name().to_str().and_then(|n| n.parse::<u32>().ok()) else { continue };
        let cmdline = std::fs::read(entry.path().join("cmdline")).unwrap_or_default();
        if !cmdline.windows(needle.len()).any(|w| w == needle) {
            continue;
        }
        // stat: "pid (comm) state ppid pgrp ...", the command name possibly with spaces.
        let stat = std::fs::read_to_string(entry.path().join("stat")).unwrap_or_default();
        let group = stat.rsplit_once(')').and_then(|(_, rest)| rest.split_whitespace().nth(2)?.parse().ok());
        found.push((pid, group.unwrap_or(0)));
    }
    found
}

/// The Chromium to run: `$CHROMIUM`, `/usr/bin/chromium` or `chromium` on the `PATH`.
pub fn find_chromium() -> Result<PathBuf, String> {
    if let Some(program) = std::env::var_os("CHROMIUM") {
        let program = PathBuf::from(program);
        return match program.is_file() {
            true => Ok(program),
            false => Err(format!("CHROMIUM={} is not a file", program.display())),
        };
    }
    let on_path = std::env::var_os("PATH")
        .map(|p| std::env::split_paths(&p).map(|dir| dir.join("chromium")).collect::<Vec<_>>())
        .unwrap_or_default();
    std::iter::once(PathBuf::from("/usr/bin/chromium")).chain(on_path).find(|p| p.is_file()).ok_or_else(
        || {
            "no Chromium: CHROMIUM is unset, and neither /usr/bin/chromium nor chromium on the PATH exists"
                .to_owned()
        },
    )
}

/// The `file://` URL of an absolute path, bytes other than unreserved ones and `/` escaped.
fn file_url(path: &Path) -> String {
    use std::os::unix::ffi::OsStrExt;
    let mut url = String::from("file://");
    for &b in path.as_os_str().as_bytes() {
        if b.is_ascii_alphanumeric() || b"/-._~".contains(&b) {
            url.push(b as char);
        } else {
            url.push_str(&format!("%{b:02X}"));
        }
    }
    url
}

/// The text of a `Runtime.ExceptionDetails`: the exception's description (or value), else the text.
fn exception_text(details: &Value) -> String {
    let exception = &details["exception"];
    match exception["description"].as_str() {
        Some(description) => description.to_owned(),
        None if !exception["value"].is_null() => {
            format!("{} {}", details["text"].as_str().unwrap_or(""), exception["value"])
        }
        None => details["text"].as_str().unwrap_or("exception").to_owned(),
    }
}

/// A console argument (`Runtime.RemoteObject`) as text.
fn remote_text(object: &Value) -> String {
    match (&object["value"], object["description"].as_str()) {
        (Value::String(s), _) => s.clone(),
        (Value::Null, Some(description)) => description.to_owned(),
        (Value::Null, None) => object["type"].as_str().unwrap_or("?").to_owned(),
        (value, _) => value.to_string(),
    }
}

/// " (url:line)" with the 1-based line, or nothing without a url.
fn location(url: &Value, line: &Value) -> String {
    match (url.as_str(), line.as_u64()) {
        (Some(url), Some(line)) if !url.is_empty() => format!(" ({url}:{})", line + 1),
        _ => String::new(),
    }
}

const SHIFT: u32 = 8;

/// What `Input.dispatchKeyEvent` needs for a key.
struct KeyInfo {
    key: String,
    code: String,
    key_code: u32,
    text: String,
    location: u32,
    modifier: u32,
}

/// The key, code and Windows key code of `key` on a US keyboard; letters are upper case with Shift.
fn key_info(key: &str, shift: bool) -> Result<KeyInfo, String> {
    const SYMBOLS: &[(&str, &str, &str, u32)] = &[
        // (unshifted, shifted, code, Windows key code)
        ("-", "_", "Minus", 189),
        ("=", "+", "Equal", 187),
        ("[", "{", "BracketLeft", 219),
        ("]", "}", "BracketRight", 221),
        ("\\", "|", "Backslash", 220),
        (";", ":", "Semicolon", 186),
        ("'", "\"", "Quote", 222),
        (",", "<", "Comma", 188),
        (".", ">", "Period", 190),
        ("/", "?", "Slash", 191),
        ("`", "~", "Backquote", 192),
        ("1", "!", "Digit1", 49),
        ("2", "@", "Digit2", 50),
        ("3", "#", "Digit3", 51),
        ("4", "$", "Digit4", 52),
        ("5", "%", "Digit5", 53),
        ("6", "^", "Digit6", 54),
        ("7", "&", "Digit7", 55),
        ("8", "*", "Digit8", 56),
        ("9", "(", "Digit9", 57),
        ("0", ")", "Digit0", 48),
    ];
    const NAMED: &[(&str, &str, u32, &str, u32, u32)] = &[
        // (key, code, Windows key code, text, location, modifier bit)
        ("Shift", "ShiftLeft", 16, "", 1, SHIFT),
        ("Control", "ControlLeft", 17, "", 1, 2),
        ("Alt", "AltLeft", 18, "", 1, 1),
        ("Meta", "MetaLeft", 91, "", 1, 4),
        ("Enter", "Enter", 13, "\r", 0, 0),
        ("Tab", "Tab", 9, "", 0, 0),
        ("Escape", "Escape", 27, "", 0, 0),
        ("Backspace", "Backspace", 8, "", 0, 0),
        ("Delete", "Delete", 46, "", 0, 0),
        ("Space", "Space", 32, " ", 0, 0),
        (" ", "Space", 32, " ", 0, 0),
        ("Home", "Home", 36, "", 0, 0),
        ("End", "End", 35, "", 0, 0),
        ("PageUp", "PageUp", 33, "", 0, 0),
        ("PageDown", "PageDown", 34, "", 0, 0),
        ("ArrowLeft", "ArrowLeft", 37, "", 0, 0),
        ("ArrowUp", "ArrowUp", 38, "", 0, 0),
        ("ArrowRight", "ArrowRight", 39, "", 0, 0),
        ("ArrowDown", "ArrowDown", 40, "", 0, 0),
    ];
    let info = |key: &str, code: &str, key_code, text: &str, location, modifier| KeyInfo {
        key: key.to_owned(),
        code: code.to_owned(),
        key_code,
        text: text.to_owned(),
        location,
        modifier,
    };
    if let Some(&(k, code, key_code, text, location, modifier)) = NAMED.iter().find(|n| n.0 == key) {
        let k = if k == "Space" { " " } else { k };
        return Ok(info(k, code, key_code, text, location, modifier));
    }
    if let Some(&(_, _, code, key_code)) = SYMBOLS.iter().find(|s| s.0 == key || s.1 == key) {
        return Ok(info(key, code, key_code, key, 0, 0));
    }
    if let [c] = key.as_bytes() {
        if c.is_ascii_alphabetic() {
            let upper = c.to_ascii_uppercase() as char;
            let key = if shift { upper.to_string() } else { key.to_owned() };
            return Ok(info(&key, &format!("Key{upper}"), upper as u32, &key, 0, 0));
        }
    }
    if let Some(n) =
        key.strip_prefix('F').and_then(|n| n.parse::<u32>().ok()).filter(|n| (1..=12).contains(n))
    {
        return Ok(info(key, key, 111 + n, "", 0, 0));
    }
    Err(format!("key {key:?}: not a key this harness knows"))
}

/// The bytes of standard base64 text (padding optional), or `None` if it is not base64.
fn base64_decode(text: &str) -> Option<Vec<u8>> {
    let mut out = Vec::with_capacity(text.len() / 4 * 3);
    let (mut acc, mut bits) = (0u32, 0);
    for c in text.bytes().filter(|&c| c != b'=') {
        let v = match c {
            b'A'..=b'Z' => c - b'A',
            b'a'..=b'z' => c - b'a' + 26,
            b'0'..=b'9' => c - b'0' + 52,
            b'+' => 62,
            b'/' => 63,
            _ => return None,
        };
        acc = ((acc << 6) | v as u32) & 0xFFFF;
        bits += 6;
        if bits >= 8 {
            bits -= 8;
            out.push((acc >> bits) as u8);
        }
    }
    Some(out)
}
