//! A virtual flight computer on the host: the flight code behind the real protocol on a
//! TCP socket (`sim-host serve`). It is the same `acs_flight::session::Session` the
//! firmware runs, so `--link tcp:` can be exercised (and the framing tested end to end)
//! without a board or QEMU. The cost counter is the host's nanosecond clock.
//!
//! One client at a time, like a board with one host link: every session starts with a
//! fresh flight computer (power-on state). A client that connects while another one is
//! served gets one framed `Error(Busy)` reply and the connection is closed (the host
//! reports "flight computer busy"). Whatever a client does — reset the connection, stop
//! reading, send garbage, go quiet for longer than the idle timeout — ends its own session
//! only; the server keeps accepting.

use acs_flight::link::{FrameAccumulator, FswMsg, HostMsg, LinkError, MAX_FRAME, encode_frame};
use acs_flight::session::{Session, board};
use anyhow::Result;
use std::io::{ErrorKind, Read, Write};
use std::net::{Shutdown, TcpListener, TcpStream};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

/// Default idle timeout: a client that sends nothing for this long (or does not take a
/// reply within it) is disconnected. A lockstep host sends a frame per control step,
/// far more often.
pub const DEFAULT_IDLE_TIMEOUT: Duration = Duration::from_secs(10);

/// Busy refusals kept open until their client has read the reply (closing at once, with
/// the client's request unread, would send a reset that can destroy the reply); beyond
/// this many the oldest is closed.
const MAX_CLOSING: usize = 16;

/// How long a busy refusal stays open for its client to read it.
const CLOSING_GRACE: Duration = Duration::from_secs(2);

/// Why a client's session ended (logged; never an error of the server).
#[derive(Debug)]
pub enum SessionEnd {
    /// The client closed the connection.
    Closed,
    /// Nothing received (or a reply not taken) within the idle timeout.
    Idle(Duration),
    /// Connection reset, broken pipe or any other I/O error of this connection.
    Io(std::io::Error),
}

impl std::fmt::Display for SessionEnd {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            SessionEnd::Closed => write!(f, "closed by the client"),
            SessionEnd::Idle(d) => write!(f, "idle for {:.1} s (timeout)", d.as_secs_f64()),
            SessionEnd::Io(e) => write!(f, "{e}"),
        }
    }
}

/// Serve one connection until the peer closes it, fails or stays idle past the stream's
/// read timeout (`idle`, for the message). Bad frames are counted by the session's
/// accumulator and reported in the step replies, as on the board.
pub fn serve_stream<S: Read + Write>(mut s: S, idle: Duration) -> SessionEnd {
    let epoch = Instant::now();
    let mut clock = move || epoch.elapsed().as_nanos() as u32;
    let mut session = Session::new(board::HOST, 1_000_000_000);
    let mut acc = FrameAccumulator::<MAX_FRAME>::new();
    let mut rx = [0u8; 4096];
    let mut tx = [0u8; MAX_FRAME];
    loop {
        let n = match s.read(&mut rx) {
            Ok(0) => return SessionEnd::Closed,
            Ok(n) => n,
            Err(e) if e.kind() == ErrorKind::Interrupted => continue,
            Err(e) if matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut) => return SessionEnd::Idle(idle),
            Err(e) => return SessionEnd::Io(e),
        };
        for &b in &rx[..n] {
            if let Some(Ok(msg)) = acc.push::<HostMsg>(b)
                && let Some(reply) = session.handle(&msg, acc.stats.dropped(), &mut clock)
                && let Ok(f) = encode_frame(&reply, &mut tx)
                && let Err(e) = s.write_all(f)
            {
                return write_end(e, idle);
            }
        }
        if let Err(e) = s.flush() {
            return write_end(e, idle);
        }
    }
}

/// A write that timed out means the client stopped reading.
fn write_end(e: std::io::Error, idle: Duration) -> SessionEnd {
    match e.kind() {
        ErrorKind::WouldBlock | ErrorKind::TimedOut => SessionEnd::Idle(idle),
        _ => SessionEnd::Io(e),
    }
}

/// Serve one TCP client with the idle timeout on both directions.
fn serve_client(c: &TcpStream, idle: Duration) -> SessionEnd {
    let setup = c
        .set_nodelay(true)
        .and_then(|()| c.set_read_timeout(Some(idle)))
        .and_then(|()| c.set_write_timeout(Some(idle)));
    if let Err(e) = setup {
        return SessionEnd::Io(e);
    }
    serve_stream(c, idle)
}

/// Answer a client that came while another is served: one `Error(Busy)` frame, then no
/// more writes. Returns the stream to keep open for a grace period (`None` if it failed).
fn refuse_busy(mut c: TcpStream) -> Option<TcpStream> {
    let mut tx = [0u8; MAX_FRAME];
    let f = encode_frame(&FswMsg::Error(LinkError::Busy), &mut tx).ok()?;
    c.set_write_timeout(Some(Duration::from_millis(200))).ok()?;
    c.write_all(f).ok()?;
    c.shutdown(Shutdown::Write).ok()?;
    Some(c)
}

/// Options of [`serve_with`].
#[derive(Clone, Debug)]
pub struct ServeOptions {
    /// Disconnect a client silent (or not reading) for this long.
    pub idle_timeout: Duration,
    /// Return after this many served sessions (busy refusals do not count); `None`: forever.
    pub max_sessions: Option<usize>,
}

impl Default for ServeOptions {
    fn default() -> Self {
        Self { idle_timeout: DEFAULT_IDLE_TIMEOUT, max_sessions: None }
    }
}

/// Accept connections forever (or `max_connections` served sessions), one client at a
/// time, with the default idle timeout.
pub fn serve(listener: TcpListener, max_connections: Option<usize>) -> Result<()> {
    serve_with(listener, &ServeOptions { max_sessions: max_connections, ..ServeOptions::default() })
}

/// Accept loop: a client is served on its own thread while this one keeps accepting (and
/// refusing others as busy). No client's fault ends it; accept errors (e.g. too many open
/// files) are logged and retried after a pause.
pub fn serve_with(listener: TcpListener, opts: &ServeOptions) -> Result<()> {
    let busy = Arc::new(AtomicBool::new(false));
    let mut closing: Vec<(TcpStream, Instant)> = Vec::new();
    let mut served = 0usize;
    for conn in listener.incoming() {
        closing.retain(|(_, t)| t.elapsed() < CLOSING_GRACE);
        let c = match conn {
            Ok(c) => c,
            Err(e) => {
                eprintln!("serve: accept failed: {e} (continuing)");
                std::thread::sleep(Duration::from_millis(50));
                continue;
            }
        };
        let peer = c.peer_addr().map_or("?".to_string(), |a| a.to_string());
        if busy.swap(true, Ordering::AcqRel) {
            eprintln!("serve: {peer}: refused, busy with another client");
            if closing.len() >= MAX_CLOSING {
                closing.remove(0);
            }
            closing.extend(refuse_busy(c).map(|c| (c, Instant::now())));
            continue;
        }
        served += 1;
        let (flag, idle) = (busy.clone(), opts.idle_timeout);
        let worker = std::thread::spawn(move || {
            eprintln!("serve: {peer}: session started");
            let end = serve_client(&c, idle);
            // Free before the client can see the close, so that its next connection is served.
            flag.store(false, Ordering::Release);
            eprintln!("serve: {peer}: session ended: {end}");
            drop(c);
        });
        if opts.max_sessions.is_some_and(|m| served >= m) {
            let _ = worker.join();
            break;
        }
    }
    Ok(())
}
