//! Raw sockets for the tests of connections and limits: a connection from
//! a chosen loopback address (all of 127.0.0.0/8 is this host's on
//! Linux), a request's whole answer and how long it took, requests
//! held in flight by a body that never comes, and whether the service closed a connection.

use std::io::{Read, Write};
use std::net::{Ipv4Addr, SocketAddr, TcpStream};
use std::time::{Duration, Instant};

/// A connection to `to` from the loopback address `from`, with a receive
/// buffer of `rcvbuf` bytes when given (a client that reads nothing fills
/// it, then the service's send buffer, sooner).
pub fn connect_from(from: Ipv4Addr, to: SocketAddr, rcvbuf: Option<u32>) -> TcpStream {
    let rt = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .unwrap();
    rt.block_on(async {
        let socket = tokio::net::TcpSocket::new_v4().unwrap();
        if let Some(n) = rcvbuf {
            socket.set_recv_buffer_size(n).unwrap();
        }
        socket.bind(SocketAddr::from((from, 0))).unwrap();
        let stream = socket.connect(to).await.unwrap();
        let std = stream.into_std().unwrap();
        std.set_nonblocking(false).unwrap();
        std
    })
}

/// Sends `request` from `from` on a new connection and reads the whole
/// answer (the service closes after it): the answer and how long it took.
pub fn timed_from(from: Ipv4Addr, to: SocketAddr, request: &str) -> (String, Duration) {
    let t = Instant::now();
    let mut s = connect_from(from, to, None);
    s.set_read_timeout(Some(Duration::from_secs(5))).unwrap();
    s.write_all(request.as_bytes()).unwrap();
    let mut out = Vec::new();
    let _ = s.read_to_end(&mut out);
    (String::from_utf8_lossy(&out).to_string(), t.elapsed())
}

/// [`timed_from`] 127.0.0.1.
pub fn timed(to: SocketAddr, request: &str) -> (String, Duration) {
    timed_from(Ipv4Addr::LOCALHOST, to, request)
}

/// A GET with `headers` (each line ending in `\r\n`), closing after it.
pub fn get(path: &str, headers: &str) -> String {
    format!("GET {path} HTTP/1.1\r\nHost: x\r\n{headers}Connection: close\r\n\r\n")
}

/// `n` connections from 127.0.0.1, each holding a request in flight: an
/// admin's `POST /v1/persons` whose 100-byte body never comes, with
/// `headers(i)` (lines ending in `\r\n`) for the i-th.
pub fn held_posts(
    to: SocketAddr,
    admin: &str,
    n: usize,
    headers: impl Fn(usize) -> String,
) -> Vec<TcpStream> {
    (0..n)
        .map(|i| {
            let mut s = TcpStream::connect(to).unwrap();
            let head = format!(
                "POST /v1/persons HTTP/1.1\r\nHost: x\r\nAuthorization: Bearer {admin}\r\n{}Content-Type: application/json\r\nContent-Length: 100\r\n\r\n{{",
                headers(i)
            );
            s.write_all(head.as_bytes()).unwrap();
            s
        })
        .collect()
}

/// True once the peer closed the connection (read gives 0 bytes or an
/// error other than a timeout).
pub fn closed(s: &TcpStream) -> bool {
    s.set_nonblocking(true).unwrap();
    let mut b = [0u8; 512];
    loop {
        match (&*s).read(&mut b) {
            Ok(0) => return true,
            Ok(_) => continue,
            Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => return false,
            Err(_) => return true,
        }
    }
}
