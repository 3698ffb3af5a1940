//! A virtual flight computer on the host: the flight code behind the real protocol on a
//! TCP socket (`sim-host serve`). It is the same `acs_flight::link::session::Session` the
//! firmware runs, so `--link tcp:` can be exercised (and the framing tested end to end)
//! without a board or QEMU. The cost counter is the host's nanosecond clock.

use acs_flight::link::session::{Session, board};
use acs_flight::link::{FrameAccumulator, HostMsg, MAX_FRAME, encode_frame};
use anyhow::Result;
use std::io::{ErrorKind, Read, Write};
use std::net::TcpListener;
use std::time::Instant;

/// Serve one connection until the peer closes it.
pub fn serve_stream<S: Read + Write>(mut s: S) -> Result<()> {
    let epoch = Instant::now();
    let mut clock = move || epoch.elapsed().as_nanos() as u32;
    let mut session = Session::new(board::HOST, 1_000_000_000);
    let mut acc = FrameAccumulator::<MAX_FRAME>::new();
    let mut rx = [0u8; 4096];
    let mut tx = [0u8; MAX_FRAME];
    loop {
        let n = match s.read(&mut rx) {
            Ok(0) => return Ok(()),
            Ok(n) => n,
            Err(e) if e.kind() == ErrorKind::Interrupted => continue,
            Err(e) if e.kind() == ErrorKind::ConnectionReset => return Ok(()),
            Err(e) => return Err(e.into()),
        };
        for &b in &rx[..n] {
            if let Some(Ok(msg)) = acc.push::<HostMsg>(b)
                && let Some(reply) = session.handle(&msg, acc.stats.dropped(), &mut clock)
                && let Ok(f) = encode_frame(&reply, &mut tx)
            {
                s.write_all(f)?;
            }
        }
        s.flush()?;
    }
}

/// Accept connections one after another, forever (or `max_connections`).
pub fn serve(listener: TcpListener, max_connections: Option<usize>) -> Result<()> {
    for (i, conn) in listener.incoming().enumerate() {
        let c = conn?;
        c.set_nodelay(true)?;
        serve_stream(c)?;
        if max_connections.is_some_and(|m| i + 1 >= m) {
            break;
        }
    }
    Ok(())
}
