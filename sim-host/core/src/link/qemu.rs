//! Processor-in-the-loop on an emulated Cortex-M4F: starts the firmware ELF in
//! `qemu-system-arm -machine mps2-an386` with UART0 on a loopback TCP socket and
//! instruction counting (`-icount shift=0`: one instruction = 1 ns of virtual time), then
//! talks the flight protocol to it.

use super::framed::Framed;
use super::{FlightLink, LinkInfo};
use acs_flight::link::{FswMsg, HostMsg, SensorFrame, StepReport};
use anyhow::{Context, Result, bail};
use std::net::{TcpListener, TcpStream};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// Default location of the QEMU firmware build (`scripts/firmware.sh build`).
pub fn default_firmware() -> PathBuf {
    if let Ok(p) = std::env::var("ACS_FIRMWARE_ELF") {
        return PathBuf::from(p);
    }
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../firmware/target/thumbv7em-none-eabihf/release/acs-firmware")
}

/// The guest clock QEMU gives the firmware.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum QemuClock {
    /// `-icount shift=0,align=off,sleep=off`: 1 instruction = 1 ns, idle time skipped
    /// (lockstep, reproducible, step costs are instruction counts).
    #[default]
    Lockstep,
    /// No `-icount`: the guest clock follows the host clock (real-time mode,
    /// `StartRealTime`). The firmware is told through the semihosting argument `realtime`,
    /// which also makes it keep its watchdog for real-time mode (docs/firmware.md).
    RealTime,
}

/// The QEMU command line for the firmware `elf` with UART0 on loopback `port`.
pub fn qemu_args(elf: &Path, port: u16, clock: QemuClock) -> Vec<String> {
    let mut args: Vec<String> =
        ["-machine", "mps2-an386", "-cpu", "cortex-m4", "-nographic", "-monitor", "none"].map(String::from).to_vec();
    let mut semi = "enable=on,target=native,chardev=semi".to_string();
    match clock {
        QemuClock::Lockstep => args.extend(["-icount", "shift=0,align=off,sleep=off"].map(String::from)),
        QemuClock::RealTime => semi.push_str(",arg=acs-firmware,arg=realtime"),
    }
    // Semihosting (binary defmt frames) to stdout, i.e. the log file.
    args.extend(["-chardev".to_string(), "stdio,id=semi".to_string(), "-semihosting-config".to_string(), semi]);
    args.extend([
        "-serial".to_string(),
        format!("tcp:127.0.0.1:{port},server=on,wait=on,nodelay=on"),
        "-kernel".to_string(),
        elf.display().to_string(),
    ]);
    args
}

pub struct QemuLink {
    child: Child,
    link: Framed<TcpStream>,
    log: PathBuf,
}

impl QemuLink {
    pub fn start(firmware: Option<&Path>) -> Result<Self> {
        Self::start_with(firmware, QemuClock::Lockstep, &[])
    }

    /// As [`start`](Self::start), on the given clock and with `extra` appended to the QEMU
    /// command line (e.g. a TCG plugin, see `sim-host cycles`).
    pub fn start_with(firmware: Option<&Path>, clock: QemuClock, extra: &[String]) -> Result<Self> {
        let elf = firmware.map(Path::to_path_buf).unwrap_or_else(default_firmware);
        if !elf.exists() {
            bail!(
                "firmware ELF {} not found: build it with `scripts/firmware.sh build` (or pass --firmware)",
                elf.display()
            );
        }
        let port = TcpListener::bind("127.0.0.1:0")?.local_addr()?.port();
        let log = std::env::temp_dir().join(format!("acs-qemu-{}-{port}.log", std::process::id()));
        let out = std::fs::File::create(&log)?;
        let child = Command::new("qemu-system-arm")
            .args(qemu_args(&elf, port, clock))
            .args(extra)
            .stdin(Stdio::null())
            .stdout(out.try_clone()?)
            .stderr(out)
            .spawn()
            .context("starting qemu-system-arm (install it: apt-get install qemu-system-arm)")?;
        let mut me_child = Some(child);
        let deadline = Instant::now() + Duration::from_secs(20);
        let stream = loop {
            match TcpStream::connect(("127.0.0.1", port)) {
                Ok(s) => break s,
                Err(_) if Instant::now() < deadline => {
                    if let Some(c) = me_child.as_mut()
                        && let Ok(Some(st)) = c.try_wait()
                    {
                        let txt = std::fs::read_to_string(&log).unwrap_or_default();
                        bail!("qemu exited ({st}) before accepting the link:\n{txt}");
                    }
                    std::thread::sleep(Duration::from_millis(20));
                }
                Err(e) => {
                    if let Some(mut c) = me_child.take() {
                        let _ = c.kill();
                        let _ = c.wait();
                    }
                    return Err(e).context("connecting to qemu's UART socket");
                }
            }
        };
        let link = Framed::from_tcp(stream, format!("qemu:{}", elf.display()))?;
        let child = me_child.take().context("qemu process lost")?;
        Ok(Self { child, link, log })
    }

    /// The underlying framed link (tests inject raw bytes through it).
    pub fn framed(&mut self) -> &mut Framed<TcpStream> {
        &mut self.link
    }

    fn with_log<T>(&mut self, r: Result<T>) -> Result<T> {
        r.map_err(|e| {
            let exited = self.child.try_wait().ok().flatten();
            let tail = std::fs::read(&self.log)
                .map(|b| String::from_utf8_lossy(&b[b.len().saturating_sub(2000)..]).into_owned())
                .unwrap_or_default();
            e.context(format!(
                "qemu {}; log {}: {tail}",
                exited.map_or("running".to_string(), |s| s.to_string()),
                self.log.display()
            ))
        })
    }
}

impl Drop for QemuLink {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
        let _ = std::fs::remove_file(&self.log);
    }
}

impl FlightLink for QemuLink {
    fn name(&self) -> String {
        "qemu".into()
    }
    fn hello(&mut self) -> Result<LinkInfo> {
        let r = self.link.hello();
        self.with_log(r)
    }
    fn request(&mut self, msg: &HostMsg) -> Result<FswMsg> {
        let r = self.link.request(msg);
        self.with_log(r)
    }
    fn step(&mut self, frame: &SensorFrame) -> Result<StepReport> {
        let r = self.link.step(frame);
        self.with_log(r)
    }
    fn frames_dropped_host(&self) -> u32 {
        self.link.frames_dropped_host()
    }
    fn anomalies(&self) -> crate::link::LinkAnomalies {
        self.link.anomalies()
    }
}
