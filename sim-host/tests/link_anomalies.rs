//! The link never steps twice on one frame and the virtual flight computer survives its
//! clients (issue 21), end to end over loopback TCP with the real binaries: `sim-host
//! serve` as the flight computer, `sim-host run --link tcp:` as the host, and a test-side
//! proxy between them that duplicates or alters one frame.
//!
//! - A duplicated host→flight Sensor frame is refused by the flight side (not stepped),
//!   reported in `summary.json` `link_anomalies`, and the run's figures and time series
//!   are bit-identical to the clean in-process run (exit 0).
//! - A duplicated reply is counted as a harmless duplicate (bit-identical, exit 0).
//! - A second, different reply to one frame (what a flight side that stepped it twice
//!   sends), or a reply to a frame not sent yet, marks the result affected: exit 3,
//!   summary.json still written.
//! - `serve` outlives a client that resets the connection while it writes, and an idle
//!   client (timed out); a client that comes while another is served is told "busy".

use acs_flight::link::{FrameAccumulator, FswMsg, HostMsg, MAX_FRAME, encode_frame};
use serde::de::DeserializeOwned;
use serde_json::Value;
use sim_core::link::FlightLink;
use sim_core::link::framed::Framed;
use sim_core::recorder::output::{first_difference, read_run};
use sim_core::recorder::series::TimeSeries;
use std::io::{BufRead, BufReader, Read, Write};
use std::net::{Shutdown, TcpListener, TcpStream};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// The example: paper 001 DMCS M1, 900 s at 10 Hz (9,000 steps).
fn dmcs() -> PathBuf {
    repo().join("scenarios/paper001/dmcs-m1.toml")
}

/// The frame the proxy tampers with (t = 10 s).
const K: u32 = 100;

/// `sim-host serve` on a free loopback port; killed on drop; stderr kept in a file.
struct Serve {
    child: Child,
    port: u16,
    log: PathBuf,
}

impl Serve {
    fn start(dir: &Path, idle_timeout_s: f64) -> Self {
        let log = dir.join("serve.log");
        let mut child = Command::new(env!("CARGO_BIN_EXE_sim-host"))
            .args(["serve", "--listen", "127.0.0.1:0", "--idle-timeout-s", &idle_timeout_s.to_string()])
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        let mut err = BufReader::new(child.stderr.take().unwrap());
        let mut first = String::new();
        err.read_line(&mut first).unwrap();
        let port = first
            .split("127.0.0.1:")
            .nth(1)
            .and_then(|r| r.split_whitespace().next())
            .and_then(|p| p.parse().ok())
            .unwrap_or_else(|| panic!("no port in {first:?}"));
        // Keep draining its log (it would block on a full pipe otherwise).
        let mut f = std::fs::File::create(&log).unwrap();
        std::thread::spawn(move || std::io::copy(&mut err, &mut f));
        Self { child, port, log }
    }

    fn addr(&self) -> String {
        format!("127.0.0.1:{}", self.port)
    }

    /// Still running (never exits on a client's fault).
    fn alive(&mut self) -> bool {
        self.child.try_wait().unwrap().is_none()
    }

    fn log(&self) -> String {
        std::fs::read_to_string(&self.log).unwrap_or_default()
    }
}

impl Drop for Serve {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

fn run(scenario: &Path, out: &Path, link: &str) -> Output {
    Command::new(env!("CARGO_BIN_EXE_sim-host"))
        .args(["run", scenario.to_str().unwrap(), "--out", out.to_str().unwrap(), "--no-plots", "--quiet"])
        .args(["--link", link])
        .output()
        .unwrap()
}

fn summary(out: &Path) -> Value {
    serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap()
}

/// The run's time series (its default `timeseries.parquet`, read back by `read_run`)
/// without the step-cost column (a clock reading, not a result).
fn series(out: &Path) -> TimeSeries {
    let mut ts = read_run(out).unwrap().series;
    assert!(out.join("timeseries.parquet").exists());
    let cost = ts.names.iter().position(|h| h == "step_cost_insns").unwrap();
    ts.names.remove(cost);
    ts.cols.remove(cost);
    ts
}

/// The figures of a run (summary.json without the link, timing and wall-clock keys).
const FIGURES: [&str; 14] = [
    "steps",
    "final_error_deg",
    "settle_time_s",
    "after_settle_from_s",
    "max_error_after_settle_deg",
    "ape_after_settle_deg",
    "mean_error_whole_run_deg",
    "rms_error_after_settle_deg",
    "final_euler_deg",
    "final_rate_rad_s",
    "max_wheel_speed_rpm",
    "max_wheel_power_w",
    "status_counts",
    "final_mode",
];

fn assert_same_result(clean: &Path, other: &Path) {
    let (a, b) = (summary(clean), summary(other));
    for k in FIGURES {
        assert!(a.get(k).is_some(), "summary has no {k}");
        assert_eq!(a[k], b[k], "summary {k} differs");
    }
    let (x, y) = (series(clean), series(other));
    assert!(!x.is_empty());
    assert_eq!(first_difference(&x, &y), None, "the time series differ");
}

#[derive(Clone, Copy)]
enum Tamper {
    /// Send host→flight Sensor frame K twice.
    DupSensor,
    /// Send the flight→host Step reply to frame K twice.
    DupReply,
    /// After the reply to frame K, a second reply to K with another command (what a
    /// flight side that stepped frame K twice would send).
    SecondStep,
    /// After the reply to frame K, a reply to frame K + 5, not sent yet.
    StepAhead,
}

/// Copy frames from `src` to `dst`; after each frame `extra` may add bytes. Returns how
/// many frames it added.
fn pump<T: DeserializeOwned>(mut src: TcpStream, mut dst: TcpStream, extra: impl Fn(&T) -> Option<Vec<u8>>) -> u32 {
    let mut acc = FrameAccumulator::<MAX_FRAME>::new();
    let (mut frame, mut buf, mut added) = (Vec::new(), [0u8; 4096], 0);
    'outer: while let Ok(n @ 1..) = src.read(&mut buf) {
        for &b in &buf[..n] {
            frame.push(b);
            let decoded = acc.push::<T>(b);
            if b != 0 {
                continue;
            }
            if dst.write_all(&frame).is_err() {
                break 'outer;
            }
            frame.clear();
            if let Some(Ok(m)) = decoded
                && let Some(x) = extra(&m)
            {
                added += 1;
                if dst.write_all(&x).is_err() {
                    break 'outer;
                }
            }
        }
    }
    let _ = dst.shutdown(Shutdown::Write);
    added
}

fn encode<T: serde::Serialize>(m: &T) -> Vec<u8> {
    let mut buf = [0u8; MAX_FRAME];
    encode_frame(m, &mut buf).unwrap().to_vec()
}

/// A one-connection proxy to `upstream`; joins to the number of frames it added.
fn proxy(upstream: String, tamper: Tamper) -> (u16, JoinHandle<u32>) {
    let l = TcpListener::bind("127.0.0.1:0").unwrap();
    let port = l.local_addr().unwrap().port();
    let h = std::thread::spawn(move || {
        let (host, _) = l.accept().unwrap();
        let flight = TcpStream::connect(upstream).unwrap();
        let (h2, f2) = (host.try_clone().unwrap(), flight.try_clone().unwrap());
        let up = std::thread::spawn(move || {
            pump::<HostMsg>(host, flight, move |m| match (tamper, m) {
                (Tamper::DupSensor, HostMsg::Sensor(f)) if f.seq == K => Some(encode(m)),
                _ => None,
            })
        });
        let down = pump::<FswMsg>(f2, h2, move |m| match (tamper, m) {
            (Tamper::DupReply, FswMsg::Step(r)) if r.cmd.seq == K => Some(encode(m)),
            (Tamper::SecondStep, FswMsg::Step(r)) if r.cmd.seq == K => {
                let mut r = *r;
                r.cmd.torque_demand_nm[0] += 1e-3;
                Some(encode(&FswMsg::Step(r)))
            }
            (Tamper::StepAhead, FswMsg::Step(r)) if r.cmd.seq == K => {
                let mut r = *r;
                r.cmd.seq += 5;
                Some(encode(&FswMsg::Step(r)))
            }
            _ => None,
        });
        up.join().unwrap() + down
    });
    (port, h)
}

fn anomalies(out: &Path) -> [u64; 5] {
    let a = &summary(out)["link_anomalies"];
    ["duplicate_replies", "late_replies", "unexpected_replies", "refusals_received", "frames_refused_flight"]
        .map(|k| a[k].as_u64().unwrap_or_else(|| panic!("link_anomalies.{k} in {a}")))
}

/// The four tampered runs against one clean in-process run of the scenario.
#[test]
fn a_duplicated_frame_is_refused_flagged_and_leaves_the_result_bit_identical() {
    let tmp = tempfile::tempdir().unwrap();
    let clean = tmp.path().join("clean");
    let r = run(&dmcs(), &clean, "in-process");
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    assert_eq!(anomalies(&clean), [0; 5]);
    assert_eq!(summary(&clean)["link_anomalies"]["result_affected"], false);
    let mut serve = Serve::start(tmp.path(), 10.0);
    // [duplicate, late, unexpected, refusals received, refused by the flight side], exit code.
    let cases = [
        (Tamper::DupSensor, "dup-sensor", [0, 0, 0, 1, 1], 0),
        (Tamper::DupReply, "dup-reply", [1, 0, 0, 0, 0], 0),
        (Tamper::SecondStep, "second-step", [0, 1, 0, 0, 0], 3),
        (Tamper::StepAhead, "step-ahead", [0, 0, 1, 0, 0], 3),
    ];
    for (tamper, name, want, code) in cases {
        let (port, proxy) = proxy(serve.addr(), tamper);
        let out = tmp.path().join(name);
        let r = run(&dmcs(), &out, &format!("tcp:127.0.0.1:{port}"));
        let err = String::from_utf8_lossy(&r.stderr);
        assert_eq!(r.status.code(), Some(code), "{name}: {err}");
        assert_eq!(proxy.join().unwrap(), 1, "{name}: the proxy tampered once");
        assert_eq!(anomalies(&out), want, "{name}");
        let a = &summary(&out)["link_anomalies"];
        assert_eq!(a["result_affected"], code == 3, "{name}");
        assert!(err.contains("link anomalies"), "{name}: not reported on stderr: {err}");
        if code == 0 {
            // Refused (or a copy dropped), not stepped: the same bits as the clean run.
            assert_same_result(&clean, &out);
        } else {
            assert!(
                err.contains("link anomalies may have changed the result")
                    && err.contains("run_status \"link_anomaly\""),
                "{err}"
            );
            assert_eq!(summary(&out)["run_status"], "link_anomaly", "{name}");
        }
        assert!(serve.alive());
    }
}

/// Hello, then `n` unconfigured Sensor frames in one write (each answered).
fn burst(n: u32) -> Vec<u8> {
    let mut v = encode(&HostMsg::Hello {
        protocol_version: acs_flight::link::PROTOCOL_VERSION,
        schema_hash: acs_flight::link::schema_hash(),
    });
    for seq in 0..n {
        v.extend(encode(&HostMsg::Sensor(acs_flight::link::SensorFrame::empty(seq, u64::from(seq) * 1000))));
    }
    v
}

/// A normal run through `serve` (paper 000 test 3, 30 s at 100 Hz), retrying while the
/// previous session is still being torn down ("busy"), for at most 5 s.
fn normal_run_succeeds(serve: &Serve, out: &Path) {
    let sc = repo().join("scenarios/paper000/test3.toml");
    let t0 = Instant::now();
    loop {
        let r = run(&sc, out, &format!("tcp:{}", serve.addr()));
        let err = String::from_utf8_lossy(&r.stderr).into_owned();
        if r.status.success() {
            return;
        }
        assert!(err.contains("busy") && t0.elapsed() < Duration::from_secs(5), "{err}");
        std::thread::sleep(Duration::from_millis(100));
    }
}

#[test]
fn serve_survives_a_reset_mid_write_and_an_idle_client_and_answers_busy() {
    let tmp = tempfile::tempdir().unwrap();
    let mut serve = Serve::start(tmp.path(), 2.0);
    // 1. Reset while the server writes: the replies to 40,000 frames (~13 MB) that the
    // client never reads fill both socket buffers, so the server blocks in a write (and
    // stops reading: the client's own write gives up after 1 s); then the client closes
    // with unread data, which makes the kernel send a reset (RST).
    {
        let mut c = TcpStream::connect(serve.addr()).unwrap();
        c.set_write_timeout(Some(Duration::from_secs(1))).unwrap();
        let _ = c.write_all(&burst(40_000));
        std::thread::sleep(Duration::from_millis(300));
        drop(c);
    }
    let t0 = Instant::now();
    // Wait for the whole log line (the reader may see "session ended: " before its reason).
    let ended = |log: &str| log.find("session ended").is_some_and(|i| log[i..].contains('\n'));
    while !ended(&serve.log()) && t0.elapsed() < Duration::from_secs(5) {
        std::thread::sleep(Duration::from_millis(50));
    }
    let log = serve.log();
    assert!(log.contains("reset") || log.contains("Broken pipe"), "no reset seen by serve: {log}");
    assert!(serve.alive(), "serve died: {log}");
    normal_run_succeeds(&serve, &tmp.path().join("after-reset"));

    // 2. An idle client holds the flight computer; another one is told it is busy, by a
    // framed reply the host reports, both through the library and the CLI.
    // The idle client says hello (so it surely holds the session: the previous run's
    // session may still be ending, then it is told "busy" and retries), then goes quiet.
    let t0 = Instant::now();
    let (mut idle, connected) = loop {
        let mut c = Framed::tcp(&serve.addr()).unwrap();
        let at = Instant::now();
        match c.hello() {
            Ok(_) => break (c, at),
            Err(e) => assert!(format!("{e:#}").contains("busy") && t0.elapsed() < Duration::from_secs(5), "{e:#}"),
        }
        std::thread::sleep(Duration::from_millis(50));
    };
    let mut second = Framed::tcp(&serve.addr()).unwrap();
    let e = format!("{:#}", second.hello().unwrap_err());
    assert!(e.contains("flight computer busy"), "{e}");
    let r =
        run(&repo().join("scenarios/paper000/test3.toml"), &tmp.path().join("busy"), &format!("tcp:{}", serve.addr()));
    assert_eq!(r.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&r.stderr).contains("flight computer busy"));
    // The idle client is disconnected after the 2 s timeout (EOF), well before 5 s.
    let e = format!("{:#}", idle.recv_timeout(Duration::from_secs(5)).unwrap_err());
    assert!(e.contains("closed the link"), "idle client not disconnected: {e}");
    let waited = connected.elapsed();
    assert!(waited > Duration::from_millis(1900) && waited < Duration::from_secs(5), "{waited:?}");
    // The server logs the disconnection after it closes the socket: wait for the line.
    let t1 = Instant::now();
    while !serve.log().contains("idle for 2.0 s") && t1.elapsed() < Duration::from_secs(5) {
        std::thread::sleep(Duration::from_millis(50));
    }
    assert!(serve.log().contains("idle for 2.0 s"), "{}", serve.log());
    assert!(serve.alive());
    normal_run_succeeds(&serve, &tmp.path().join("after-idle"));
    // A client that sends garbage and leaves ends only its own session, too.
    {
        let mut c = TcpStream::connect(serve.addr()).unwrap();
        c.write_all(&[0x55; 5000]).unwrap();
        c.write_all(&[0]).unwrap();
    }
    normal_run_succeeds(&serve, &tmp.path().join("after-garbage"));
    assert!(serve.alive());
}
