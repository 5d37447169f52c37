//! The preview's HTTP server: hyper's HTTP/1 server on a one-thread tokio runtime. It serves
//! the page (compiled into the binary), one stream of server-sent events per page, and the
//! page's choice of frame and view; nothing from disk.
//!
//! Safe by default: it answers only requests whose `Host` names the address it is bound to
//! (`localhost` or a loopback address when bound to loopback; any address when bound to all),
//! so a page of another site that has a name of its own resolve to this machine (DNS
//! rebinding) is refused; a request from another site's page (an `Origin` other than the
//! page's own) is refused too. Connections, open pages and the time to send a request's
//! headers are bounded.

use std::convert::Infallible;
use std::net::{IpAddr, SocketAddr, TcpListener};
use std::pin::Pin;
use std::sync::Arc;
use std::task::{Context, Poll};
use std::time::Duration;

use hyper::body::{Bytes, Frame, Incoming, SizeHint};
use hyper::header::{self, HeaderValue};
use hyper::service::service_fn;
use hyper::{Method, Request, Response, StatusCode};
use hyper_util::rt::{TokioIo, TokioTimer};
use tokio::sync::mpsc;

use super::board::Board;
use super::slots::Slots;
use raytrace_core::error::Error;

/// The page, with its script and style: no build step, nothing else to fetch.
const PAGE: &str = include_str!("page.html");

/// Most connections open at once; the next takes the slot of the one that has waited longest
/// for a request ([`Slots`]), so connections that send nothing (half-open, or kept alive and
/// idle) do not keep a page's request waiting.
const MAX_CONNECTIONS: usize = 64;

/// The longest a client may take to send a request's headers.
const HEADER_TIMEOUT: Duration = Duration::from_secs(10);

/// How often an idle stream sends a comment, so that a page that went away is noticed.
const HEARTBEAT: Duration = Duration::from_secs(2);

/// Largest side, in pixels, a page may ask its image to fit in.
const MAX_PAGE_SIDE: u32 = 16384;

/// Binds `addr` (port 0: a free port), for [`serve`].
pub(crate) fn bind(addr: SocketAddr) -> Result<TcpListener, Error> {
    TcpListener::bind(addr).map_err(|e| Error::resource(format!("cannot listen on {addr}: {e}")))
}

/// Serves the pages of `board` on `listener` for ever.
pub(crate) fn serve(listener: TcpListener, board: Arc<Board>) -> Result<(), Error> {
    let fail = |e: std::io::Error| Error::resource(format!("preview server: {e}"));
    let bound = listener.local_addr().map_err(fail)?;
    listener.set_nonblocking(true).map_err(fail)?;
    let runtime = tokio::runtime::Builder::new_current_thread()
        .enable_io()
        .enable_time()
        .build()
        .map_err(fail)?;
    let hosts = Arc::new(Hosts(bound.ip()));
    runtime.block_on(async move {
        let listener = tokio::net::TcpListener::from_std(listener).map_err(fail)?;
        let slots = Slots::new(MAX_CONNECTIONS);
        loop {
            let stream = match listener.accept().await {
                Ok((stream, _)) => stream,
                // Out of file descriptors, say: try again shortly.
                Err(_) => {
                    tokio::time::sleep(Duration::from_millis(50)).await;
                    continue;
                }
            };
            // Every connection inside a request or streaming: this one is closed.
            let Some(slot) = slots.admit() else { continue };
            let slot = Arc::new(slot);
            let (board, hosts) = (Arc::clone(&board), Arc::clone(&hosts));
            let held = Arc::clone(&slot);
            let task = tokio::spawn(async move {
                let service = service_fn(move |request| {
                    held.set_busy(true);
                    let reply = answer(&request, &board, &hosts);
                    // A stream holds its connection while the page is open.
                    held.set_busy(matches!(reply.body(), Body::Events(_)));
                    async move { Ok::<_, Infallible>(reply) }
                });
                let _ = hyper::server::conn::http1::Builder::new()
                    .timer(TokioTimer::new())
                    .header_read_timeout(HEADER_TIMEOUT)
                    .serve_connection(TokioIo::new(stream), service)
                    .await;
            });
            slot.serving(task.abort_handle());
        }
    })
}

/// The host names a request may give: those of the bound address.
struct Hosts(IpAddr);

impl Hosts {
    /// Whether `host` (a `Host` header, or an absolute-form target's authority: a name or
    /// address, and maybe a port) names the bound address. The port is not compared: a
    /// tunnel (`ssh -L`) may forward another. One authority or nothing ([`host_name`]).
    fn allows(&self, host: &str) -> bool {
        let Some(name) = host_name(host) else {
            return false;
        };
        let bound = self.0;
        if name.eq_ignore_ascii_case("localhost") {
            return bound.is_loopback() || bound.is_unspecified();
        }
        match name.parse::<IpAddr>() {
            Ok(ip) => {
                ip == bound || bound.is_unspecified() || (bound.is_loopback() && ip.is_loopback())
            }
            Err(_) => false,
        }
    }
}

/// The host of an authority `host[:port]` (RFC 3986, 3.2: an IPv6 address in brackets), or
/// `None` where `authority` is not one: user-info (`127.0.0.1:1@evil.example`), a port that
/// is not digits, anything after an address's closing bracket (`[::1]evil.example`).
fn host_name(authority: &str) -> Option<&str> {
    let (name, port) = match authority.strip_prefix('[') {
        Some(rest) => {
            let (address, after) = rest.split_once(']')?;
            match after {
                "" => (address, ""),
                _ => (address, after.strip_prefix(':')?),
            }
        }
        None => authority.rsplit_once(':').unwrap_or((authority, "")),
    };
    let plain = |c: char| c.is_ascii_alphanumeric() || matches!(c, '.' | '-' | ':');
    (!name.is_empty() && name.chars().all(plain) && port.bytes().all(|b| b.is_ascii_digit()))
        .then_some(name)
}

/// The request's one `Host` header (`""` where it gives none or several: a second one could
/// name another host behind the first), and the authority of an absolute-form target
/// (`GET http://evil.example/`), which names the host in its place (RFC 9112, 3.2.2).
fn hosts_named(request: &Request<Incoming>) -> (&str, Option<&str>) {
    let mut given = request.headers().get_all(header::HOST).iter();
    let host = match (given.next(), given.next()) {
        (Some(h), None) => h.to_str().unwrap_or(""),
        _ => "",
    };
    (host, request.uri().authority().map(|a| a.as_str()))
}

/// The answer to `request`.
fn answer(request: &Request<Incoming>, board: &Arc<Board>, hosts: &Hosts) -> Response<Body> {
    let (host, target) = hosts_named(request);
    if !hosts.allows(host) || target.is_some_and(|t| !hosts.allows(t)) {
        return text(
            StatusCode::FORBIDDEN,
            "refused: the Host header does not name this server's address\n",
        );
    }
    if let Some(origin) = request.headers().get(header::ORIGIN)
        && origin.as_bytes() != format!("http://{host}").as_bytes()
    {
        return text(
            StatusCode::FORBIDDEN,
            "refused: a request from another site's page\n",
        );
    }
    let query = request.uri().query().unwrap_or("");
    match (request.method(), request.uri().path()) {
        (&Method::GET, "/") => page(),
        (&Method::GET, "/events") => events(board, query),
        (&Method::POST, "/view") => choose(board, query),
        (&Method::GET | &Method::HEAD, _) => text(StatusCode::NOT_FOUND, "not found\n"),
        _ => text(StatusCode::METHOD_NOT_ALLOWED, "method not allowed\n"),
    }
}

/// The value of `name` in a query string (`a=1&b=2`), if given.
fn param<'a>(query: &'a str, name: &str) -> Option<&'a str> {
    query
        .split('&')
        .filter_map(|pair| pair.split_once('='))
        .find(|(k, _)| *k == name)
        .map(|(_, v)| v)
}

/// The page.
fn page() -> Response<Body> {
    let mut r = Response::new(Body::Full(Some(Bytes::from_static(PAGE.as_bytes()))));
    let h = r.headers_mut();
    h.insert(
        header::CONTENT_TYPE,
        HeaderValue::from_static("text/html; charset=utf-8"),
    );
    // The page's own script and style only; images from data: URLs; no framing.
    h.insert(
        header::CONTENT_SECURITY_POLICY,
        HeaderValue::from_static(
            "default-src 'none'; script-src 'unsafe-inline'; style-src 'unsafe-inline'; \
             img-src data:; connect-src 'self'; frame-ancestors 'none'",
        ),
    );
    h.insert(header::CACHE_CONTROL, HeaderValue::from_static("no-store"));
    h.insert(
        header::X_CONTENT_TYPE_OPTIONS,
        HeaderValue::from_static("nosniff"),
    );
    h.insert(
        header::REFERRER_POLICY,
        HeaderValue::from_static("no-referrer"),
    );
    r
}

/// A page's stream of events (`/events?w=W&h=H`: the size in pixels its image may take).
fn events(board: &Arc<Board>, query: &str) -> Response<Body> {
    let side = |name| {
        param(query, name)
            .and_then(|v| v.parse::<u32>().ok())
            .map(|v| v.clamp(16, MAX_PAGE_SIDE))
    };
    let size = side("w")
        .zip(side("h"))
        .unwrap_or((MAX_PAGE_SIDE, MAX_PAGE_SIDE));
    let Some(open) = board.open_page(size) else {
        return text(
            StatusCode::SERVICE_UNAVAILABLE,
            "too many pages are open: close one\n",
        );
    };
    // One event in flight: a page that reads slowly is sent the latest, not a queue.
    let (sender, receiver) = mpsc::channel::<Bytes>(1);
    let board = Arc::clone(board);
    tokio::spawn(async move {
        let _open = open;
        let mut version = board.subscribe();
        let mut seen = 0;
        loop {
            let (events, now) = board.catch_up(seen);
            seen = now;
            for e in events {
                if sender.send(e).await.is_err() {
                    return;
                }
            }
            tokio::select! {
                changed = version.changed() => if changed.is_err() { return },
                _ = sender.closed() => return,
                _ = tokio::time::sleep(HEARTBEAT) => {
                    if sender.send(Bytes::from_static(b": still here\n\n")).await.is_err() {
                        return;
                    }
                }
            }
        }
    });
    let mut r = Response::new(Body::Events(receiver));
    let h = r.headers_mut();
    h.insert(
        header::CONTENT_TYPE,
        HeaderValue::from_static("text/event-stream"),
    );
    h.insert(header::CACHE_CONTROL, HeaderValue::from_static("no-store"));
    r
}

/// A page chooses the frame and view shown (`/view?frame=N&view=NAME`, either or both).
fn choose(board: &Board, query: &str) -> Response<Body> {
    let frame = match param(query, "frame").map(str::parse::<u32>) {
        None => None,
        Some(Ok(f)) => Some(f),
        Some(Err(_)) => return text(StatusCode::BAD_REQUEST, "frame: not a frame number\n"),
    };
    match board.choose(frame, param(query, "view")) {
        Ok(()) => {
            let mut r = Response::new(Body::Full(None));
            *r.status_mut() = StatusCode::NO_CONTENT;
            r
        }
        Err(why) => text(StatusCode::BAD_REQUEST, &format!("{why}\n")),
    }
}

/// A plain-text answer. A refusal (4xx, 5xx) closes its connection: a client refused,
/// a page beyond the most that may be open, say, does not keep a connection's slot.
fn text(status: StatusCode, message: &str) -> Response<Body> {
    let mut r = Response::new(Body::Full(Some(Bytes::from(message.to_string()))));
    *r.status_mut() = status;
    r.headers_mut().insert(
        header::CONTENT_TYPE,
        HeaderValue::from_static("text/plain; charset=utf-8"),
    );
    if status.is_client_error() || status.is_server_error() {
        r.headers_mut()
            .insert(header::CONNECTION, HeaderValue::from_static("close"));
    }
    r
}

/// A response's body: whole, or a page's stream of events.
enum Body {
    Full(Option<Bytes>),
    Events(mpsc::Receiver<Bytes>),
}

impl hyper::body::Body for Body {
    type Data = Bytes;
    type Error = Infallible;

    fn poll_frame(
        self: Pin<&mut Self>,
        cx: &mut Context<'_>,
    ) -> Poll<Option<Result<Frame<Bytes>, Infallible>>> {
        match self.get_mut() {
            Body::Full(b) => Poll::Ready(b.take().map(|b| Ok(Frame::data(b)))),
            Body::Events(r) => r.poll_recv(cx).map(|e| e.map(|b| Ok(Frame::data(b)))),
        }
    }

    fn is_end_stream(&self) -> bool {
        matches!(self, Body::Full(None))
    }

    fn size_hint(&self) -> SizeHint {
        match self {
            Body::Full(b) => SizeHint::with_exact(b.as_ref().map_or(0, |b| b.len() as u64)),
            Body::Events(_) => SizeHint::default(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_the_bound_address_is_a_host() {
        let loopback = Hosts("127.0.0.1".parse().unwrap());
        for ok in [
            "127.0.0.1:8765",
            "localhost:8765",
            "LOCALHOST",
            "[::1]:9",
            "127.0.0.2",
        ] {
            assert!(loopback.allows(ok), "{ok}");
        }
        for refused in [
            "evil.example:8765",
            "10.0.0.1:8765",
            "",
            "localhost.evil.example",
        ] {
            assert!(!loopback.allows(refused), "{refused}");
        }
        // One authority, or nothing: text after the brackets, user-info, a port that is not
        // digits, an IPv6 address without brackets.
        for refused in [
            "[::1]evil.example",
            "[::1]:80x",
            "[::1",
            "127.0.0.1:1@evil.example",
            "user@127.0.0.1",
            "127.0.0.1:evil",
            "127.0.0.1 evil.example",
            "::1",
        ] {
            assert!(!loopback.allows(refused), "{refused}");
        }
        let one = Hosts("10.1.2.3".parse().unwrap());
        assert!(one.allows("10.1.2.3:80"));
        assert!(!one.allows("localhost:80"));
        assert!(!one.allows("10.1.2.4:80"));
        let all = Hosts("0.0.0.0".parse().unwrap());
        assert!(all.allows("10.1.2.4:80") && all.allows("[fe80::1]:80"));
        assert!(!all.allows("node.example:80"));
        assert!(!all.allows("127.0.0.1:1@evil.example"));
    }

    #[test]
    fn query_values_are_found_by_name() {
        assert_eq!(param("w=300&h=200", "h"), Some("200"));
        assert_eq!(param("w=300&hh=200", "h"), None);
    }
}
