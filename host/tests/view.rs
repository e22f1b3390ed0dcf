//! `host view` under a virtual X server (Xvfb) on lavapipe, driven by xdotool as a user drives
//! it: the viewer accumulates to --max-spp, reacts to keys (next estimator, split view, next
//! integrator, next lookup), a mouse drag (orbit) and a resize, and each screenshot (P) equals
//! `host render` of the scene file it saved, byte for byte (EXR and PNG), on the GPU and on the
//! CPU. Without a display it
//! says how to get one. Needs Xvfb and xdotool (`./scripts/test.sh` installs them).

use std::io::{BufRead, BufReader};
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::sync::mpsc::{channel, Receiver};
use std::time::{Duration, Instant};

const HOST: &str = env!("CARGO_BIN_EXE_host");

/// A virtual X server on a free display number, killed on drop.
struct Xvfb {
    child: Child,
    display: String,
}

impl Xvfb {
    fn start() -> Xvfb {
        // One display per test of this process (the tests run in parallel threads).
        static NEXT: std::sync::atomic::AtomicU32 = std::sync::atomic::AtomicU32::new(0);
        let k = NEXT.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        let base = 100 + (std::process::id() % 70) * 10 + k * 1000;
        let n = (base..base + 10)
            .find(|n| !Path::new(&format!("/tmp/.X11-unix/X{n}")).exists())
            .expect("a free X display number");
        let child = Command::new("Xvfb")
            .args([
                format!(":{n}").as_str(),
                "-screen",
                "0",
                "640x480x24",
                "-nolisten",
                "tcp",
            ])
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap_or_else(|e| {
                panic!(
                    "the viewer test needs Xvfb ({e}): `sudo apt-get install -y xvfb xdotool` \
                     (./scripts/test.sh installs them)"
                )
            });
        let socket = format!("/tmp/.X11-unix/X{n}");
        let t = Instant::now();
        let mut x = Xvfb {
            child,
            display: format!(":{n}"),
        };
        while !Path::new(&socket).exists() {
            assert!(
                x.child.try_wait().unwrap().is_none(),
                "Xvfb :{n} exited at start"
            );
            assert!(
                t.elapsed() < Duration::from_secs(20),
                "Xvfb :{n} did not start"
            );
            std::thread::sleep(Duration::from_millis(50));
        }
        x
    }

    fn xdotool(&self, args: &[&str]) -> String {
        // `timeout`: a search for a window that never comes must not hang the test run.
        let out = Command::new("timeout")
            .arg("60")
            .arg("xdotool")
            .args(args)
            .env("DISPLAY", &self.display)
            .output()
            .unwrap_or_else(|e| panic!("xdotool ({e}): `sudo apt-get install -y xdotool`"));
        assert!(
            out.status.success(),
            "xdotool {args:?}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        String::from_utf8_lossy(&out.stdout).trim().to_owned()
    }
}

impl Drop for Xvfb {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// The viewer's stdout, line by line, as it comes.
struct Lines {
    rx: Receiver<String>,
    seen: Vec<String>,
}

impl Lines {
    /// Waits (at most `secs`) for a line containing `text`; returns it.
    fn wait_for(&mut self, text: &str, secs: u64) -> String {
        self.try_wait_for(text, secs).unwrap_or_else(|| {
            panic!(
                "no line with {text:?} within {secs} s; the viewer printed:\n{}",
                self.seen.join("\n")
            )
        })
    }

    /// [`Lines::wait_for`], or None after `secs`.
    fn try_wait_for(&mut self, text: &str, secs: u64) -> Option<String> {
        let t = Instant::now();
        loop {
            let left = Duration::from_secs(secs).saturating_sub(t.elapsed());
            let line = self.rx.recv_timeout(left).ok()?;
            self.seen.push(line.clone());
            if line.contains(text) {
                return Some(line);
            }
        }
    }

    /// Sends the input `args` through xdotool until the viewer answers with `expect` (X input
    /// to a window without a window manager can be lost while it maps or takes the focus).
    fn act(&mut self, x: &Xvfb, args: &[&str], expect: &str) -> String {
        for _ in 0..5 {
            x.xdotool(args);
            if let Some(line) = self.try_wait_for(expect, 20) {
                return line;
            }
        }
        panic!(
            "xdotool {args:?}: no line with {expect:?}; the viewer printed:\n{}",
            self.seen.join("\n")
        )
    }
}

/// Starts `host view ARGS` on `x`'s display; its stdout comes through the returned lines.
fn view(x: &Xvfb, args: &[&str]) -> (Child, Lines) {
    let mut child = Command::new(HOST)
        .arg("view")
        .args(args)
        .env("DISPLAY", &x.display)
        .env_remove("WAYLAND_DISPLAY")
        .stdout(Stdio::piped())
        .stderr(Stdio::inherit())
        .spawn()
        .unwrap();
    let out = child.stdout.take().unwrap();
    let (tx, rx) = channel();
    std::thread::spawn(move || {
        for line in BufReader::new(out).lines().map_while(Result::ok) {
            if tx.send(line).is_err() {
                break;
            }
        }
    });
    (
        child,
        Lines {
            rx,
            seen: Vec::new(),
        },
    )
}

/// The process's exit within `secs` (killed and failed otherwise).
fn wait_exit(child: &mut Child, secs: u64) -> std::process::ExitStatus {
    let t = Instant::now();
    loop {
        if let Some(s) = child.try_wait().unwrap() {
            return s;
        }
        if t.elapsed() > Duration::from_secs(secs) {
            let _ = child.kill();
            panic!("the viewer did not exit within {secs} s");
        }
        std::thread::sleep(Duration::from_millis(50));
    }
}

/// Scripted input; then the screenshot and `host render` of its scene file are the same bytes.
fn scripted_session(backend: &str) {
    let x = Xvfb::start();
    let dir = tempfile::tempdir().unwrap();
    let save = dir.path().join("shots");
    let args = [
        "--volume",
        "cloud",
        "--resolution",
        "32",
        "--width",
        "40",
        "--height",
        "30",
        "--max-spp",
        "5",
        "--frame-spp",
        "2",
        "--backend",
        backend,
        "--save-dir",
        save.to_str().unwrap(),
    ];
    let (mut child, mut lines) = view(&x, &args);
    // Lavapipe builds the pipelines on first use: minutes on a cold shader cache.
    lines.wait_for("reached 5 spp", 600);
    let win = x.xdotool(&["search", "--sync", "--name", "host view"]);
    let win = win.lines().next().unwrap().to_owned();
    // No window manager: give the window the keyboard focus.
    x.xdotool(&["windowfocus", "--sync", &win]);
    lines.act(&x, &["key", "e"], "estimator: restarted");
    lines.wait_for("reached 5 spp", 600);
    let drag = [
        "mousemove",
        "--window",
        &win,
        "10",
        "10",
        "mousedown",
        "1",
        "mousemove",
        "--window",
        &win,
        "25",
        "14",
        "mouseup",
        "1",
    ];
    lines.act(&x, &drag, "orbit: restarted");
    lines.act(&x, &["key", "b"], "split view: restarted");
    lines.wait_for("reached 5 spp", 600);
    let wrote = lines.act(&x, &["key", "p"], "view: wrote");
    assert!(wrote.contains("view-0001.toml"), "{wrote}");
    // The next integrator (free-flight: single scattering, which reads no estimator, so the
    // split view ends), then the next lookup (the volume packed anew).
    lines.act(&x, &["key", "i"], "integrator: restarted");
    lines.act(
        &x,
        &["key", "l"],
        "lookup trilinear: loading the volume anew",
    );
    lines.wait_for("reached 5 spp", 600);
    // A resize renders at the window's new size.
    let resize = ["windowsize", win.as_str(), "56", "44"];
    lines.act(&x, &resize, "window size 56x44: restarted");
    lines.wait_for("reached 5 spp", 600);
    let wrote = lines.act(&x, &["key", "p"], "view: wrote");
    assert!(wrote.contains("view-0002.toml"), "{wrote}");
    x.xdotool(&["key", "Escape"]);
    let status = wait_exit(&mut child, 60);
    assert!(status.success(), "the viewer exited with {status}");

    let shot = save.join("view-0001");
    let scene = std::fs::read_to_string(shot.with_extension("toml")).unwrap();
    // The estimator after the jackknife, and a camera the orbit moved off the default one.
    assert!(scene.contains("estimator = \"naive\""), "{scene}");
    assert!(scene.contains("spp = 5"), "{scene}");
    let second = save.join("view-0002");
    let scene2 = std::fs::read_to_string(second.with_extension("toml")).unwrap();
    assert!(scene2.contains("integrator = \"free-flight\""), "{scene2}");
    assert!(scene2.contains("lookup = \"trilinear\""), "{scene2}");
    assert!(!scene2.contains("estimator"), "{scene2}");
    assert!(
        scene2.contains("width = 56") && scene2.contains("height = 44"),
        "{scene2}\nthe viewer printed:\n{}",
        lines.seen.join("\n")
    );
    let render = |scene: &Path, out: &Path| {
        let r = Command::new(HOST)
            .args(["render", scene.to_str().unwrap()])
            .args(["--out", out.to_str().unwrap(), "-q", "--backend", backend])
            .output()
            .unwrap();
        assert!(
            r.status.success(),
            "host render of {}: {}",
            scene.display(),
            String::from_utf8_lossy(&r.stderr)
        );
    };
    let out = dir.path().join("again.exr");
    render(&shot.with_extension("toml"), &out);
    for ext in ["exr", "png"] {
        let a = std::fs::read(shot.with_extension(ext)).unwrap();
        let b = std::fs::read(out.with_extension(ext)).unwrap();
        assert!(
            a == b,
            "{backend}: the screenshot's {ext} differs from host render's"
        );
    }
    // The orbit moved the camera: the same scene with the default camera is another image.
    let moved: String = scene
        .lines()
        .filter(|l| !l.starts_with("camera") && !l.starts_with("look-at"))
        .map(|l| format!("{l}\n"))
        .collect();
    let default_scene = dir.path().join("default.toml");
    std::fs::write(&default_scene, moved).unwrap();
    let default_out = dir.path().join("default.exr");
    render(&default_scene, &default_out);
    assert_ne!(
        std::fs::read(&default_out).unwrap(),
        std::fs::read(shot.with_extension("exr")).unwrap(),
        "the orbit did not move the saved camera"
    );
}

#[test]
fn scripted_session_on_lavapipe_reproduces_with_host_render() {
    scripted_session("gpu");
}

#[test]
fn scripted_session_on_the_cpu_reproduces_with_host_render() {
    scripted_session("cpu");
}

#[test]
fn without_a_display_it_says_how_to_get_one() {
    let out = Command::new(HOST)
        .args(["view", "--volume", "constant", "--resolution", "8"])
        .env_remove("DISPLAY")
        .env_remove("WAYLAND_DISPLAY")
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("needs a display") && err.contains("xvfb-run"),
        "{err}"
    );
}
