//! A live lens lab: one scene, loaded and its BVH built once, rendered progressively on a
//! thread of its own while clients change the lens, focus, stop and film. Each change cancels
//! the pass under way, re-derives only what it touches (see [`session`]), shows a coarse first
//! pass at once and refines it pass by pass. `realcam serve` puts a web page and a JSON API in
//! front of it; the library API here is what both use.

pub mod lenses;
pub mod session;
pub mod settings;

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{Receiver, RecvTimeoutError, Sender, channel};
use std::sync::{Arc, Condvar, Mutex, MutexGuard};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use serde_json::{Map, Value, json};

use crate::film::Image;
use crate::film::format::{ImageFormat, Tone, encode_image};
use crate::lens::Prescription;
use crate::lens::diagram::draw_report_diagram;
use crate::lens::report::LensReport;
use crate::lens::settings::LensSettings;
use crate::pipeline::{PassCancel, RenderStats};
use crate::sync::lock;
use session::Session;

/// What the render thread is asked to do.
enum Request {
    /// New settings (a JSON object of changes); answers the new state or a refusal.
    Settings(Value, Sender<Result<Value, String>>),
    /// Focus on what the image shows at this pixel.
    FocusAt([f64; 2], Sender<Result<Value, String>>),
    /// Write the picture and the film to the session's outputs.
    Save(Sender<Result<Value, String>>),
    Stop,
}

/// The latest image and numbers, for any number of readers.
#[derive(Clone)]
pub struct Published {
    /// Increases with every publication (a new image, a change of settings, an error), so a
    /// reader holding two states can tell which is newer: answers to concurrent requests may
    /// arrive in any order.
    pub revision: u64,
    /// Increases with every new image.
    pub generation: u64,
    /// Increases with every change of settings.
    pub settings_generation: u64,
    pub image: Option<Arc<Image>>,
    /// Exposure (linear scale) of the 8-bit picture of `image`.
    pub exposure: f32,
    pub state: Map<String, Value>,
    pub stats: Map<String, Value>,
    /// The lens and the options its report and diagram are derived with.
    pub lens: Option<(Arc<Prescription>, LensSettings)>,
}

/// The lens report (JSON, SVG) of one settings generation.
type LensReportCache = (u64, Arc<Value>, Arc<String>);

struct Shared {
    published: Mutex<Published>,
    /// Signalled at every publication (or when the session stops).
    published_changed: Condvar,
    cancel: Arc<AtomicBool>,
    stopped: AtomicBool,
    png: Mutex<Option<(u64, Arc<Vec<u8>>)>>,
    lens_report: Mutex<Option<LensReportCache>>,
}

/// A running live session: cheap to share between connection threads.
#[derive(Clone)]
pub struct LiveLab {
    shared: Arc<Shared>,
    requests: Arc<Mutex<Sender<Request>>>,
    thread: Arc<Mutex<Option<JoinHandle<()>>>>,
    library: Arc<lenses::LensLibrary>,
}

/// How long a client waits for the render thread to take up a request.
const REPLY_TIMEOUT: Duration = Duration::from_secs(60);

impl LiveLab {
    /// Starts rendering `session` on a thread of its own.
    pub fn start(session: Session, cancel: Arc<AtomicBool>) -> LiveLab {
        let shared = Arc::new(Shared {
            published: Mutex::new(Published {
                revision: 0,
                generation: 0,
                settings_generation: 0,
                image: None,
                exposure: 1.0,
                state: Map::new(),
                stats: Map::new(),
                lens: None,
            }),
            published_changed: Condvar::new(),
            cancel,
            stopped: AtomicBool::new(false),
            png: Mutex::new(None),
            lens_report: Mutex::new(None),
        });
        let library = Arc::new(session.library().clone());
        let (sender, receiver) = channel();
        // The first state is published here, before any request can ask for it.
        let render_loop = RenderLoop::new(session, Arc::clone(&shared));
        let thread = std::thread::Builder::new()
            .name("realcam-live".into())
            .spawn(move || render_loop.run(receiver))
            .expect("cannot start the render thread");
        LiveLab {
            shared,
            requests: Arc::new(Mutex::new(sender)),
            thread: Arc::new(Mutex::new(Some(thread))),
            library,
        }
    }

    /// The lenses a client may pick.
    pub fn lenses(&self) -> Vec<lenses::LensEntry> {
        self.library.entries()
    }

    /// Creates the cancellation flag a [`Session`] is built with.
    pub fn cancel_flag() -> (Arc<AtomicBool>, PassCancel) {
        let flag = Arc::new(AtomicBool::new(false));
        (Arc::clone(&flag), PassCancel(flag))
    }

    fn ask(
        &self,
        request: impl FnOnce(Sender<Result<Value, String>>) -> Request,
    ) -> Result<Value, String> {
        if self.shared.stopped.load(Ordering::Relaxed) {
            return Err("the session has stopped".into());
        }
        let (reply, answer) = channel();
        // Abandon the pass under way: the request is taken up as soon as it stops.
        self.shared.cancel.store(true, Ordering::Relaxed);
        lock(&self.requests)
            .send(request(reply))
            .map_err(|_| "the render thread has stopped".to_string())?;
        answer
            .recv_timeout(REPLY_TIMEOUT)
            .map_err(|_| "the render thread did not answer".to_string())?
    }

    /// Applies a JSON object of changes (see [`settings::LiveSettings::changed`]); the new state,
    /// or why the changes were refused (the settings then stay as they were).
    pub fn change(&self, changes: Value) -> Result<Value, String> {
        self.ask(|reply| Request::Settings(changes, reply))
    }

    /// Focuses on what pixel (`x`, `y`) of the image shows, through the lens.
    pub fn focus_at(&self, x: f64, y: f64) -> Result<Value, String> {
        self.ask(|reply| Request::FocusAt([x, y], reply))
    }

    /// Writes the picture and the linear film to the session's outputs.
    pub fn save(&self) -> Result<Value, String> {
        self.ask(Request::Save)
    }

    pub fn published(&self) -> Published {
        lock(&self.shared.published).clone()
    }

    /// The current settings with `spp_done`, `spp_target` and the lens's derived data.
    pub fn state(&self) -> Value {
        Value::Object(lock(&self.shared.published).state.clone())
    }

    pub fn stats(&self) -> Value {
        Value::Object(lock(&self.shared.published).stats.clone())
    }

    /// Waits until an image newer than `generation` is out (or `timeout` passes); returns the
    /// latest generation.
    pub fn wait_for_image(&self, generation: u64, timeout: Duration) -> u64 {
        self.wait_while(timeout, |p| p.generation <= generation)
            .generation
    }

    /// Waits until something newer than `revision` is published (or `timeout` passes); returns
    /// the latest revision.
    pub fn wait_for_revision(&self, revision: u64, timeout: Duration) -> u64 {
        self.wait_while(timeout, |p| p.revision <= revision)
            .revision
    }

    /// The published state once `waiting` says false of it, the session stops or `timeout`
    /// passes (every publication wakes the waiters).
    fn wait_while(
        &self,
        timeout: Duration,
        waiting: impl Fn(&Published) -> bool,
    ) -> MutexGuard<'_, Published> {
        let published = lock(&self.shared.published);
        self.shared
            .published_changed
            .wait_timeout_while(published, timeout, |p| {
                waiting(p) && !self.shared.stopped.load(Ordering::Relaxed)
            })
            .unwrap_or_else(|e| e.into_inner())
            .0
    }

    /// The current image as PNG (encoded once per image), with its generation.
    pub fn png(&self) -> Result<(u64, Arc<Vec<u8>>), String> {
        let published = self.published();
        let mut cache = lock(&self.shared.png);
        if let Some((generation, bytes)) = &*cache
            && *generation == published.generation
        {
            return Ok((*generation, Arc::clone(bytes)));
        }
        let image = published.image.ok_or("no image yet")?;
        let mut bytes = Vec::new();
        encode_image(
            &mut bytes,
            &image,
            ImageFormat::Png,
            Tone::exposure(published.exposure),
        )
        .map_err(|e| e.to_string())?;
        let bytes = Arc::new(bytes);
        *cache = Some((published.generation, Arc::clone(&bytes)));
        Ok((published.generation, bytes))
    }

    /// What `realcam lens --json` prints for the current lens and settings, and its diagram
    /// with ray fans (SVG); derived once per change.
    pub fn lens_report(&self) -> Result<(Arc<Value>, Arc<String>), String> {
        let published = self.published();
        let mut cache = lock(&self.shared.lens_report);
        if let Some((generation, json, svg)) = &*cache
            && *generation == published.settings_generation
        {
            return Ok((Arc::clone(json), Arc::clone(svg)));
        }
        let (prescription, options) = published.lens.ok_or("no lens yet")?;
        let report =
            LensReport::derive((*prescription).clone(), &options).map_err(|e| format!("{e:#}"))?;
        let svg = draw_report_diagram(&report, None);
        let (json, svg) = (Arc::new(report.to_json()), Arc::new(svg));
        *cache = Some((
            published.settings_generation,
            Arc::clone(&json),
            Arc::clone(&svg),
        ));
        Ok((json, svg))
    }

    /// Stops the render thread (the pass under way is abandoned) and waits for it.
    pub fn stop(&self) {
        self.shared.cancel.store(true, Ordering::Relaxed);
        let _ = lock(&self.requests).send(Request::Stop);
        if let Some(thread) = lock(&self.thread).take() {
            let _ = thread.join();
        }
        self.shared.stopped.store(true, Ordering::Relaxed);
        self.shared.published_changed.notify_all();
    }

    pub fn is_stopped(&self) -> bool {
        self.shared.stopped.load(Ordering::Relaxed)
    }
}

/// The render thread: takes requests between passes, renders a coarse first pass after each
/// change, then full passes up to the target spp, publishing each image.
struct RenderLoop {
    session: Session,
    shared: Arc<Shared>,
    /// A change is waiting for its coarse first pass.
    preview_due: bool,
    /// Seconds of full-resolution passes since the change, for samples per second.
    pass_seconds: f64,
    settings_generation: u64,
    passes_cancelled: u64,
    /// When the last change arrived, and how long until its first image was out.
    changed_at: Instant,
    first_image_seconds: Option<f64>,
    /// A render failure, shown in the state until the next change.
    error: Option<String>,
}

impl RenderLoop {
    fn new(session: Session, shared: Arc<Shared>) -> RenderLoop {
        let mut run = RenderLoop {
            session,
            shared,
            preview_due: true,
            pass_seconds: 0.0,
            settings_generation: 1,
            passes_cancelled: 0,
            changed_at: Instant::now(),
            first_image_seconds: None,
            error: None,
        };
        run.publish(None);
        run
    }

    fn run(mut self, requests: Receiver<Request>) {
        loop {
            let busy = self.error.is_none()
                && (self.preview_due || self.session.spp_done < self.session.spp_target());
            let request = if busy {
                requests.try_recv().ok()
            } else {
                match requests.recv_timeout(Duration::from_millis(500)) {
                    Ok(request) => Some(request),
                    Err(RecvTimeoutError::Timeout) => continue,
                    Err(RecvTimeoutError::Disconnected) => return,
                }
            };
            if let Some(request) = request {
                self.shared.cancel.store(false, Ordering::Relaxed);
                if !self.handle(request) {
                    return;
                }
                continue;
            }
            if let Err(e) = self.render_step() {
                self.error = Some(format!("{e:#}"));
                self.publish(None);
            }
        }
    }

    /// Takes up one request; false to stop.
    fn handle(&mut self, request: Request) -> bool {
        match request {
            Request::Stop => return false,
            Request::Settings(changes, reply) => {
                let outcome = self
                    .session
                    .settings()
                    .changed(&changes)
                    .and_then(|next| self.session.apply(next));
                self.answer(outcome, reply);
            }
            Request::FocusAt([x, y], reply) => {
                let outcome = self
                    .session
                    .focus_at_pixel(x, y)
                    .and_then(|changes| self.session.settings().changed(&changes))
                    .and_then(|next| self.session.apply(next));
                self.answer(outcome, reply);
            }
            Request::Save(reply) => {
                let _ = reply.send(self.session.save());
            }
        }
        true
    }

    /// Restarts accumulation after an accepted change and answers with the new state.
    fn answer(&mut self, outcome: Result<(), String>, reply: Sender<Result<Value, String>>) {
        match outcome {
            Ok(()) => {
                self.restart();
                let state = Value::Object(lock(&self.shared.published).state.clone());
                let _ = reply.send(Ok(state));
            }
            Err(refusal) => {
                let _ = reply.send(Err(refusal));
            }
        }
    }

    fn restart(&mut self) {
        self.preview_due = true;
        self.session.spp_done = 0;
        self.pass_seconds = 0.0;
        self.settings_generation += 1;
        self.changed_at = Instant::now();
        self.first_image_seconds = None;
        self.error = None;
        self.publish(None);
    }

    fn render_step(&mut self) -> anyhow::Result<()> {
        if self.preview_due {
            self.preview_due = false;
            let preview = self.session.render_preview()?;
            if self.shared.cancel.load(Ordering::Relaxed) {
                self.passes_cancelled += 1;
            }
            self.session.begin_accumulation()?;
            if let Some(image) = preview {
                self.first_image(&image);
                self.publish(Some(image));
            }
            return Ok(());
        }
        let start = Instant::now();
        if self.session.render_next_pass()? {
            // The image is part of the pass: on a GPU, reading it back waits for the pass.
            let image = self.session.image()?;
            self.pass_seconds += start.elapsed().as_secs_f64();
            self.first_image(&image);
            self.publish(Some(image));
        } else {
            self.passes_cancelled += 1;
        }
        Ok(())
    }

    fn first_image(&mut self, _image: &Image) {
        if self.first_image_seconds.is_none() {
            self.first_image_seconds = Some(self.changed_at.elapsed().as_secs_f64());
        }
    }

    /// Publishes the state and stats, and `image` when there is a new one.
    fn publish(&mut self, image: Option<Image>) {
        let session = &self.session;
        let mut state = session.settings_json();
        state.insert("spp_done".into(), json!(session.spp_done));
        state.insert("spp_target".into(), json!(session.spp_target()));
        state.insert("lens_info".into(), session.lens_info());
        state.insert(
            "out".into(),
            json!(session.spec().output.out.display().to_string()),
        );
        state.insert(
            "exr".into(),
            json!(
                session
                    .spec()
                    .output
                    .exr
                    .as_ref()
                    .map(|p| p.display().to_string())
            ),
        );
        state.insert("command".into(), json!(session.command_line()));
        state.insert("error".into(), json!(self.error));
        state.insert("warning".into(), json!(session.warning()));
        let render_stats = session.renderer().world.resource::<RenderStats>();
        let (width, height) = session.size();
        let samples = session.spp_done as f64 * (width as f64 * height as f64);
        let mut stats = Map::new();
        for (name, value) in [
            ("device", json!(session.renderer().device())),
            ("scene_loads", json!(render_stats.scene_loads)),
            ("bvh_builds", json!(render_stats.bvh_builds)),
            ("triangles", json!(render_stats.triangles)),
            ("spp_done", json!(session.spp_done)),
            ("spp_target", json!(session.spp_target())),
            (
                "samples_per_second",
                json!(if self.pass_seconds > 0.0 {
                    samples / self.pass_seconds
                } else {
                    0.0
                }),
            ),
            ("passes_cancelled", json!(self.passes_cancelled)),
            ("settings_changes", json!(self.settings_generation - 1)),
            ("first_image_seconds", json!(self.first_image_seconds)),
        ] {
            stats.insert(name.into(), value);
        }
        let lens = (
            Arc::new(session.prescription().clone()),
            session.spec().lens.clone(),
        );
        let exposure = image.as_ref().map(|i| session.exposure(i));
        let mut published = lock(&self.shared.published);
        published.revision += 1;
        state.insert("revision".into(), json!(published.revision));
        state.insert("generation".into(), json!(published.generation));
        if let (Some(image), Some(exposure)) = (image, exposure) {
            published.generation += 1;
            state.insert("generation".into(), json!(published.generation));
            published.image = Some(Arc::new(image));
            published.exposure = exposure;
        }
        published.settings_generation = self.settings_generation;
        published.state = state;
        published.stats = stats;
        published.lens = Some(lens);
        drop(published);
        self.shared.published_changed.notify_all();
    }
}
