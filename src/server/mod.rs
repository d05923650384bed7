//! `realcam serve`'s web front end: the page (plain HTML, CSS and JavaScript built into the
//! binary) and the JSON API over a [`LiveLab`], on a small thread-per-connection HTTP/1.1
//! server. A bad request gets a 4xx answer with `{"error": …}`; it never reaches the render.

pub mod http;

use std::io::Write;
use std::net::{SocketAddr, TcpListener, TcpStream};
use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Duration;

use serde_json::{Value, json};

use crate::live::LiveLab;
use http::{Request, Response, read_request};

const INDEX_HTML: &str = include_str!("page/index.html");
const APP_JS: &str = include_str!("page/app.js");
const STYLE_CSS: &str = include_str!("page/style.css");

/// Connections served at once; more wait in the listen queue or are turned away.
const MAX_CONNECTIONS: usize = 64;
/// Event streams open at once (each holds a connection).
const MAX_EVENT_STREAMS: usize = 16;
/// An event stream sends a comment this often, so dead clients are noticed.
const KEEP_ALIVE: Duration = Duration::from_secs(15);

/// A listening server.
pub struct Server {
    listener: TcpListener,
    lab: LiveLab,
    connections: Arc<AtomicUsize>,
    event_streams: Arc<AtomicUsize>,
}

impl Server {
    /// Binds `address` (port 0: any free port).
    pub fn bind(address: SocketAddr, lab: LiveLab) -> anyhow::Result<Server> {
        let listener = TcpListener::bind(address)
            .map_err(|e| anyhow::anyhow!("cannot listen on {address}: {e}"))?;
        listener.set_nonblocking(true)?;
        Ok(Server {
            listener,
            lab,
            connections: Arc::new(AtomicUsize::new(0)),
            event_streams: Arc::new(AtomicUsize::new(0)),
        })
    }

    pub fn local_addr(&self) -> SocketAddr {
        self.listener
            .local_addr()
            .expect("a bound listener has an address")
    }

    /// Serves until `stop()` says so (checked at least every 100 ms).
    pub fn serve(&self, stop: impl Fn() -> bool) {
        use std::os::fd::AsRawFd;
        while !stop() && !self.lab.is_stopped() {
            // Wait for a connection or the next look at `stop`, whichever comes first.
            let mut ready = libc::pollfd {
                fd: self.listener.as_raw_fd(),
                events: libc::POLLIN,
                revents: 0,
            };
            unsafe { libc::poll(&mut ready, 1, 100) };
            match self.listener.accept() {
                Ok((stream, _)) => self.spawn(stream),
                Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => {}
                // Out of file descriptors, say: let connections finish before trying again.
                Err(_) => std::thread::sleep(Duration::from_millis(50)),
            }
        }
    }

    fn spawn(&self, mut stream: TcpStream) {
        let _ = stream.set_nonblocking(false);
        let _ = stream.set_write_timeout(Some(Duration::from_secs(30)));
        if self.connections.fetch_add(1, Ordering::SeqCst) >= MAX_CONNECTIONS {
            self.connections.fetch_sub(1, Ordering::SeqCst);
            let _ = Response::error(503, "too many connections; try again").write_to(&mut stream);
            return;
        }
        let (lab, connections, streams) = (
            self.lab.clone(),
            Arc::clone(&self.connections),
            Arc::clone(&self.event_streams),
        );
        let spawned = std::thread::Builder::new()
            .name("realcam-http".into())
            .spawn(move || {
                handle_connection(&lab, stream, &streams);
                connections.fetch_sub(1, Ordering::SeqCst);
            });
        if spawned.is_err() {
            self.connections.fetch_sub(1, Ordering::SeqCst);
        }
    }
}

fn handle_connection(lab: &LiveLab, mut stream: TcpStream, streams: &AtomicUsize) {
    let request = match read_request(&stream) {
        Ok(request) => request,
        Err(refusal) => {
            let _ = refusal.write_to(&mut stream);
            return;
        }
    };
    if (request.method.as_str(), request.path.as_str()) == ("GET", "/api/events") {
        if streams.fetch_add(1, Ordering::SeqCst) >= MAX_EVENT_STREAMS {
            streams.fetch_sub(1, Ordering::SeqCst);
            let _ = Response::error(503, "too many event streams open").write_to(&mut stream);
            return;
        }
        let _ = event_stream(lab, &mut stream);
        streams.fetch_sub(1, Ordering::SeqCst);
        return;
    }
    let response = route(lab, &request);
    let _ = response.write_to(&mut stream);
}

/// Server-sent events: `image` each time a new image is out, `state` when only the state
/// changed (new settings, an error); both carry `{revision, generation, spp_done,
/// settings_generation}`.
fn event_stream(lab: &LiveLab, stream: &mut TcpStream) -> std::io::Result<()> {
    stream.write_all(
        b"HTTP/1.1 200 OK\r\nContent-Type: text/event-stream\r\nCache-Control: no-store\r\nConnection: close\r\n\r\n",
    )?;
    let (mut seen_revision, mut seen_generation) = (0, 0);
    loop {
        let published = lab.published();
        if published.revision > seen_revision {
            seen_revision = published.revision;
            let kind = if published.generation > seen_generation {
                "image"
            } else {
                "state"
            };
            seen_generation = published.generation;
            let data = json!({
                "revision": published.revision,
                "generation": published.generation,
                "spp_done": published.state.get("spp_done"),
                "settings_generation": published.settings_generation,
            });
            write!(stream, "event: {kind}\ndata: {data}\n\n")?;
        } else {
            stream.write_all(b": keep-alive\n\n")?;
        }
        stream.flush()?;
        if lab.is_stopped() {
            return Ok(());
        }
        lab.wait_for_revision(seen_revision, KEEP_ALIVE);
    }
}

/// The page's own origin may post; another site's page in the same browser may not.
fn cross_site(request: &Request) -> bool {
    match (request.header("origin"), request.header("host")) {
        (Some(origin), Some(host)) => {
            let origin = origin
                .trim_start_matches("http://")
                .trim_start_matches("https://");
            origin != host
        }
        (Some(_), None) => true,
        _ => false,
    }
}

fn json_body(request: &Request) -> Result<Value, Response> {
    if request.body.is_empty() {
        return Err(Response::error(400, "expected a JSON object in the body"));
    }
    serde_json::from_slice(&request.body)
        .map_err(|e| Response::error(400, format!("the body is not valid JSON: {e}")))
}

fn answer(outcome: Result<Value, String>) -> Response {
    match outcome {
        Ok(value) => Response::json(200, &value),
        Err(message) => Response::error(400, message),
    }
}

pub fn route(lab: &LiveLab, request: &Request) -> Response {
    let method = request.method.as_str();
    if method == "POST" && cross_site(request) {
        return Response::error(403, "requests from another site's page are refused");
    }
    let get = |response: fn(&LiveLab) -> Response| match method {
        "GET" => response(lab),
        _ => Response::error(405, format!("{} takes GET", request.path)),
    };
    let post = |response: &dyn Fn() -> Response| match method {
        "POST" => response(),
        _ => Response::error(405, format!("{} takes POST", request.path)),
    };
    match request.path.as_str() {
        "/" | "/index.html" => {
            get(|_| Response::bytes("text/html; charset=utf-8", INDEX_HTML.into()))
        }
        "/app.js" => get(|_| Response::bytes("text/javascript; charset=utf-8", APP_JS.into())),
        "/style.css" => get(|_| Response::bytes("text/css; charset=utf-8", STYLE_CSS.into())),
        "/api/state" => get(|lab| Response::json(200, &lab.state())),
        "/api/stats" => get(|lab| Response::json(200, &lab.stats())),
        "/api/lenses" => get(|lab| {
            let state = lab.state();
            Response::json(
                200,
                &json!({ "current": state.get("lens"), "lenses": lab.lenses() }),
            )
        }),
        "/api/image.png" => get(|lab| match lab.png() {
            Ok((generation, png)) => {
                let mut response = Response::bytes("image/png", png.to_vec());
                response
                    .extra_headers
                    .push(("X-Realcam-Generation", generation.to_string()));
                response
            }
            Err(message) => Response::error(503, message),
        }),
        "/api/lens.json" => get(|lab| match lab.lens_report() {
            Ok((json, _)) => Response::json(200, &json),
            Err(message) => Response::error(500, message),
        }),
        "/api/lens.svg" => get(|lab| match lab.lens_report() {
            Ok((_, svg)) => Response::bytes("image/svg+xml", svg.as_bytes().to_vec()),
            Err(message) => Response::error(500, message),
        }),
        "/api/settings" => post(&|| match json_body(request) {
            Ok(changes) => answer(lab.change(changes)),
            Err(refusal) => refusal,
        }),
        "/api/focus" => post(&|| match json_body(request) {
            Ok(point) => match (
                point.get("x").and_then(Value::as_f64),
                point.get("y").and_then(Value::as_f64),
            ) {
                (Some(x), Some(y)) => answer(lab.focus_at(x, y)),
                _ => Response::error(400, "expected {\"x\": …, \"y\": …}, a pixel of the image"),
            },
            Err(refusal) => refusal,
        }),
        "/api/save" => post(&|| answer(lab.save())),
        _ => Response::error(404, format!("no such page: {}", request.path)),
    }
}
