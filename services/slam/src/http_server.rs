//! The HTTP listener: the accept loop in front of the API's router, with the limits a
//! service open to a network needs.
//!
//! Sits between the socket and [`sketchslam_api::router()`]. `axum::serve` has no limits of its
//! own: a client that opens a connection and sends its headers a byte a minute, or a body
//! that never ends, holds a task and a socket for ever, and nothing bounds how many such
//! connections there are. Here:
//! - **at most `max_connections` at once**: beyond that the loop stops accepting (new
//!   connections wait in the kernel's backlog) until one closes;
//! - **headers within `header_read_timeout`** (hyper's HTTP/1 header-read timeout): it runs
//!   from the moment the connection waits for a request, so a connection that sends
//!   nothing, sends its headers too slowly, or sits idle between keep-alive requests is
//!   closed;
//! - **a request, body included, within `request_timeout`** (408 otherwise, tower-http's
//!   `TimeoutLayer`; the body is read inside the handler), and no pause longer than
//!   `header_read_timeout` between two pieces of a body (`RequestBodyTimeoutLayer`). A
//!   response that streams (the event stream) is not bounded: its handler has returned.
//!
//! HTTP/1.1 only: every client of this API (curl, reqwest, browsers without TLS) speaks it.
//! On shutdown the loop stops accepting, open connections finish their requests
//! (bounded by `drain_timeout`), and the function returns.

use std::future::Future;
use std::sync::Arc;
use std::time::Duration;

use axum::Router;
use axum::http::StatusCode;
use hyper::server::conn::http1;
use hyper_util::rt::{TokioIo, TokioTimer};
use hyper_util::server::graceful::GracefulShutdown;
use hyper_util::service::TowerToHyperService;
use tokio::net::TcpListener;
use tokio::sync::Semaphore;
use tower_http::timeout::{RequestBodyTimeoutLayer, TimeoutLayer};

/// The listener's limits (module doc).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HttpLimits {
    /// Connections served at once.
    pub max_connections: usize,
    /// A request's headers must arrive within this of the connection waiting for them;
    /// also the longest pause inside a request body.
    pub header_read_timeout: Duration,
    /// A request, from its headers to the handler's answer (body read included).
    pub request_timeout: Duration,
    /// How long open connections may take to finish after shutdown begins.
    pub drain_timeout: Duration,
}

impl Default for HttpLimits {
    fn default() -> Self {
        Self {
            max_connections: 512,
            header_read_timeout: Duration::from_secs(10),
            request_timeout: Duration::from_secs(120),
            drain_timeout: Duration::from_secs(30),
        }
    }
}

/// Serves `app` on `listener` within `limits` until `shutdown` completes, then drains the
/// open connections (module doc). Errors accepting a connection (too many open files, a
/// reset before accept) are logged and the loop goes on.
pub async fn serve_http(
    listener: TcpListener,
    app: Router,
    limits: HttpLimits,
    shutdown: impl Future<Output = ()> + Send + 'static,
) {
    let app = app
        .layer(RequestBodyTimeoutLayer::new(limits.header_read_timeout))
        .layer(TimeoutLayer::with_status_code(
            StatusCode::REQUEST_TIMEOUT,
            limits.request_timeout,
        ));
    let permits = Arc::new(Semaphore::new(limits.max_connections.max(1)));
    let graceful = GracefulShutdown::new();
    // hyper's own HTTP/1 connection, not hyper-util's `auto` one: `auto` first reads to
    // tell HTTP/1 from HTTP/2, without a timeout, so a connection that sends nothing was
    // never closed.
    let mut builder = http1::Builder::new();
    builder
        .timer(TokioTimer::new())
        .header_read_timeout(limits.header_read_timeout);
    tokio::pin!(shutdown);
    loop {
        let permit = tokio::select! {
            permit = permits.clone().acquire_owned() => match permit {
                Ok(permit) => permit,
                Err(_) => break,
            },
            () = &mut shutdown => break,
        };
        let stream = tokio::select! {
            accepted = listener.accept() => match accepted {
                Ok((stream, _)) => stream,
                Err(e) => {
                    tracing::warn!(error = %e, "accepting a connection failed");
                    // Out of file descriptors: give the open connections a moment.
                    tokio::time::sleep(Duration::from_millis(50)).await;
                    continue;
                }
            },
            () = &mut shutdown => break,
        };
        let service = TowerToHyperService::new(app.clone());
        let connection = builder.serve_connection(TokioIo::new(stream), service);
        let connection = graceful.watch(connection);
        tokio::spawn(async move {
            if let Err(e) = connection.await {
                tracing::debug!(error = %e, "connection ended with an error");
            }
            drop(permit);
        });
    }
    drop(listener);
    tokio::select! {
        () = graceful.shutdown() => {}
        () = tokio::time::sleep(limits.drain_timeout) => {
            tracing::warn!("connections still open after the drain timeout");
        }
    }
}
