//! `reprise serve`: the live characters in a browser.
//!
//! - `GET /` is the page, `GET /app.js` its script, `GET /world` what the page needs to
//!   draw (labels, systems, fps, triangles or bones, the quantization box).
//! - `GET /session?systems=reprise,crossfade&start=neutral&seed=1` upgrades to a
//!   WebSocket: one [`reprise_live::session::Session`] per connection. The server steps it
//!   at the corpus frame rate and sends each frame as one binary message
//!   ([`protocol::encode_frame`]); the client sends commands as text
//!   ([`reprise_live::command::LiveCommand`]), each answered by a text message
//!   (`{"ok": …}` or `{"error": …}`); a bad one is refused and the session goes on.
//! - **Bounds**: loopback unless `--listen` says otherwise; at most `--max-sessions`
//!   sessions (more get HTTP 503); messages of at most [`limits::MAX_MESSAGE_BYTES`];
//!   at most [`limits::COMMANDS_PER_SECOND`] commands per second per session (a burst of
//!   [`limits::BURST`]; beyond it, refused), and a client that keeps flooding is
//!   disconnected; a session lasts at most `--max-minutes`. No message names a file.
//! - `GET /stats`: the server's own timings ([`stats::Report`]): making a frame, tick
//!   lateness, command to first frame.
//! - **Recording**: when a session ends its [`reprise_live::session::Recording`] is
//!   written to `--record-dir` (a new file per session, never one that exists), for
//!   `reprise replay`.

pub mod limits;
pub mod protocol;
pub mod record;
pub mod stats;

use std::net::SocketAddr;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Duration;

use axum::extract::ws::{Message, WebSocket, WebSocketUpgrade};
use axum::extract::{Query, State};
use axum::http::{header, StatusCode};
use axum::response::{IntoResponse, Response};
use axum::routing::get;
use axum::Router;
use reprise_live::command::Message as ClientMessage;
use reprise_live::game::GameFile;
use reprise_live::session::Session;
use reprise_live::systems::SYSTEM_IDS;
use reprise_live::world::{Paths, Tuning, World};
use serde::Deserialize;
use tokio::sync::Semaphore;

use crate::limits::{RateLimit, MAX_MESSAGE_BYTES};
use crate::protocol::Quantizer;
use crate::stats::{Measure, Stats};

/// `reprise-serve` (run as `reprise serve`, which finds the artifacts of a pipeline).
#[derive(Debug, Clone, clap::Parser)]
#[command(name = "reprise-serve", version, about)]
pub struct Args {
    /// The directory holding the pipeline's artifacts under their default names
    /// (gplvm_models.parquet, …, controls.parquet); a file flag below overrides one.
    #[arg(long, value_name = "DIR", default_value = ".")]
    pub artifacts: PathBuf,
    /// `gplvm_models.parquet`.
    #[arg(long, value_name = "FILE")]
    pub gplvm_models: Option<PathBuf>,
    /// `gplvm_latents.parquet`.
    #[arg(long, value_name = "FILE")]
    pub latents: Option<PathBuf>,
    /// `pca_models.parquet`.
    #[arg(long, value_name = "FILE")]
    pub pca_models: Option<PathBuf>,
    /// `scales.parquet`.
    #[arg(long, value_name = "FILE")]
    pub scales: Option<PathBuf>,
    /// `bridges.parquet`.
    #[arg(long, value_name = "FILE")]
    pub bridges: Option<PathBuf>,
    /// `labeled_frames.parquet`.
    #[arg(long, value_name = "FILE")]
    pub labeled_frames: Option<PathBuf>,
    /// `mg_nodes.parquet`.
    #[arg(long, value_name = "FILE")]
    pub mg_nodes: Option<PathBuf>,
    /// `mg_edges.parquet`.
    #[arg(long, value_name = "FILE")]
    pub mg_edges: Option<PathBuf>,
    /// `controls.parquet` (names the rig).
    #[arg(long, value_name = "FILE")]
    pub controls: Option<PathBuf>,
    /// Address to listen on. Loopback by default; another address exposes the server.
    #[arg(long, default_value = "127.0.0.1:8024")]
    pub listen: SocketAddr,
    /// At most this many sessions at once.
    #[arg(long, default_value_t = 32)]
    pub max_sessions: usize,
    /// A session ends after this many minutes.
    #[arg(long, default_value_t = 60.0)]
    pub max_minutes: f64,
    /// Where each session's recording is written.
    #[arg(long, value_name = "DIR", default_value = "recordings")]
    pub record_dir: PathBuf,
    /// The Tic-Tac-Toe game file (reactions to game events as scripts of commands;
    /// `reprise_live::game`). Without it the page's game has no reactions.
    #[arg(long, value_name = "FILE")]
    pub game: Option<PathBuf>,
}

impl Args {
    /// The artifacts: each file flag given, or its default name in `--artifacts`.
    pub fn paths(&self) -> Paths {
        let d = Paths::in_dir(&self.artifacts);
        let pick = |given: &Option<PathBuf>, default: PathBuf| given.clone().unwrap_or(default);
        Paths {
            gplvm_models: pick(&self.gplvm_models, d.gplvm_models),
            latents: pick(&self.latents, d.latents),
            pca_models: pick(&self.pca_models, d.pca_models),
            scales: pick(&self.scales, d.scales),
            bridges: pick(&self.bridges, d.bridges),
            labeled_frames: pick(&self.labeled_frames, d.labeled_frames),
            mg_nodes: pick(&self.mg_nodes, d.mg_nodes),
            mg_edges: pick(&self.mg_edges, d.mg_edges),
            controls: pick(&self.controls, d.controls),
        }
    }
}

/// Why the server cannot run.
#[derive(Debug, thiserror::Error)]
pub enum ServeError {
    /// The artifacts.
    #[error("{0}")]
    Load(#[from] reprise_stagekit::StageError),
    /// The address or the runtime.
    #[error("{0}")]
    Io(#[from] std::io::Error),
    /// Bad arguments.
    #[error("{0}")]
    Config(String),
}

/// What every request handler shares.
pub struct App {
    world: &'static World,
    quant: Quantizer,
    sessions: Arc<Semaphore>,
    max_sessions: usize,
    stats: Stats,
    max_minutes: f64,
    record_dir: PathBuf,
    world_json: String,
    game: Option<Arc<GameFile>>,
}

impl App {
    /// The app over `world`.
    ///
    /// # Errors
    /// [`ServeError::Load`] if the rig fails on the training frames.
    pub fn new(
        world: &'static World,
        max_sessions: usize,
        max_minutes: f64,
        record_dir: PathBuf,
        game: Option<GameFile>,
    ) -> Result<Self, ServeError> {
        let quant = Quantizer::of_world(world)?;
        let world_json = protocol::world_json(world, &quant, game.as_ref());
        Ok(Self {
            world,
            quant,
            sessions: Arc::new(Semaphore::new(max_sessions)),
            max_sessions,
            stats: Stats::default(),
            max_minutes,
            record_dir,
            world_json,
            game: game.map(Arc::new),
        })
    }
}

/// The routes over `app`.
pub fn router(app: Arc<App>) -> Router {
    Router::new()
        .route("/", get(|| async { ([(header::CONTENT_TYPE, "text/html; charset=utf-8")], PAGE) }))
        .route("/app.js", get(|| async { ([(header::CONTENT_TYPE, "text/javascript; charset=utf-8")], SCRIPT) }))
        .route(
            "/world",
            get(|State(app): State<Arc<App>>| async move {
                ([(header::CONTENT_TYPE, "application/json")], app.world_json.clone())
            }),
        )
        .route(
            "/stats",
            get(|State(app): State<Arc<App>>| async move {
                let open = app.max_sessions - app.sessions.available_permits();
                let body = serde_json::to_string(&app.stats.report(open)).unwrap_or_default();
                ([(header::CONTENT_TYPE, "application/json")], body)
            }),
        )
        .route("/session", get(session))
        .with_state(app)
}

/// The page.
pub const PAGE: &str = include_str!("../assets/index.html");
/// Its script.
pub const SCRIPT: &str = include_str!("../assets/app.js");

/// A session's query string.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct Start {
    systems: Option<String>,
    start: Option<String>,
    seed: Option<u64>,
}

/// A frame not taken by the client within this long ends its session.
pub const SEND_TIMEOUT: Duration = Duration::from_secs(10);

/// Command arrivals remembered between two frames, for [`Measure::CommandToFrame`].
const MAX_PENDING_ARRIVALS: usize = 64;

/// The most systems one session may run.
const MAX_SYSTEMS: usize = SYSTEM_IDS.len();

async fn session(
    State(app): State<Arc<App>>,
    query: Result<Query<Start>, axum::extract::rejection::QueryRejection>,
    ws: WebSocketUpgrade,
) -> Response {
    let Ok(Query(q)) = query else {
        return (StatusCode::BAD_REQUEST, "the query is systems=a,b&start=label&seed=n").into_response();
    };
    let systems: Vec<String> = q
        .systems
        .as_deref()
        .unwrap_or("reprise,motion-graphs,motion-matching,crossfade")
        .split(',')
        .map(str::to_string)
        .collect();
    if systems.len() > MAX_SYSTEMS {
        return (StatusCode::BAD_REQUEST, format!("at most {MAX_SYSTEMS} systems")).into_response();
    }
    let world = app.world;
    let start = q.start.unwrap_or_else(|| world.labels[0].clone());
    let session = match Session::new(world, &systems, &start, q.seed.unwrap_or(0)) {
        Ok(s) => match &app.game {
            Some(g) => s.with_game(Arc::clone(g)),
            None => s,
        },
        Err(e) => return (StatusCode::BAD_REQUEST, e).into_response(),
    };
    let Ok(permit) = Arc::clone(&app.sessions).try_acquire_owned() else {
        return (StatusCode::SERVICE_UNAVAILABLE, "too many sessions; try again later").into_response();
    };
    ws.max_message_size(MAX_MESSAGE_BYTES).max_frame_size(MAX_MESSAGE_BYTES).on_upgrade(move |socket| async move {
        run_session(app.clone(), session, socket).await;
        drop(permit);
    })
}

/// Steps `session` at the frame rate, streaming frames and taking commands, until the
/// client leaves, floods, or the session's time is up; then writes its recording.
async fn run_session(app: Arc<App>, mut session: Session, mut socket: WebSocket) {
    let world = app.world;
    let mut tick = tokio::time::interval(Duration::from_secs_f64(1.0 / world.fps));
    tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    let deadline = tokio::time::Instant::now() + Duration::from_secs_f64(app.max_minutes * 60.0);
    let mut rate = RateLimit::new(tokio::time::Instant::now().into_std());
    let mut game_version = session.game().map(|g| g.version);
    // Arrivals of the commands taken since the last frame (at most the rate limit's burst
    // and a frame's refill; bounded again here).
    let mut arrivals: Vec<std::time::Instant> = Vec::new();
    loop {
        tokio::select! {
            due = tick.tick() => {
                let began = std::time::Instant::now();
                app.stats.record(Measure::TickLate, began.saturating_duration_since(due.into_std()));
                if tokio::time::Instant::now() > deadline {
                    let _ = socket.send(Message::Text(r#"{"error":"the session's time is up"}"#.into())).await;
                    break;
                }
                let frame = session.frame();
                let frames = session.step();
                let bytes = match protocol::encode_frame(world, &app.quant, frame, &session.recording().systems, &frames) {
                    Ok(b) => b,
                    Err(e) => {
                        let _ = socket.send(Message::Text(protocol::error_json(&e.to_string()).into())).await;
                        break;
                    }
                };
                app.stats.record(Measure::FrameMake, began.elapsed());
                // A client that stops reading is dropped rather than left holding a session.
                match tokio::time::timeout(SEND_TIMEOUT, socket.send(Message::Binary(bytes.into()))).await {
                    Ok(Ok(())) => {}
                    _ => break,
                }
                for a in arrivals.drain(..) {
                    app.stats.record(Measure::CommandToFrame, a.elapsed());
                }
                // The character moved (its turn ended on this frame): the page is told.
                if let Some(g) = session.game().filter(|g| Some(g.version) != game_version) {
                    game_version = Some(g.version);
                    if socket.send(Message::Text(protocol::game_json(g).into())).await.is_err() {
                        break;
                    }
                }
            }
            msg = socket.recv() => {
                let text = match msg {
                    Some(Ok(Message::Text(t))) => t,
                    Some(Ok(Message::Binary(_))) => {
                        let _ = socket.send(Message::Text(protocol::error_json("commands are JSON text").into())).await;
                        continue;
                    }
                    Some(Ok(Message::Ping(_) | Message::Pong(_))) => continue,
                    // Closed, or an oversized or malformed frame: the session ends.
                    Some(Ok(Message::Close(_))) | Some(Err(_)) | None => break,
                };
                let reply = match rate.take(tokio::time::Instant::now().into_std()) {
                    limits::Verdict::Allow => match ClientMessage::parse(text.as_str(), &world.labels) {
                        Ok(ClientMessage::Command(c)) => match session.command(c) {
                            Ok(outcomes) => {
                                if arrivals.len() < MAX_PENDING_ARRIVALS {
                                    arrivals.push(std::time::Instant::now());
                                }
                                protocol::outcomes_json(session.frame(), &session.recording().systems, &outcomes)
                            }
                            Err(e) => protocol::error_json(&e),
                        },
                        Ok(ClientMessage::Game(a)) => match session.act(a) {
                            Ok(g) => {
                                game_version = Some(g.version);
                                protocol::game_json(g)
                            }
                            Err(e) => protocol::error_json(&e),
                        },
                        Err(e) => protocol::error_json(&e),
                    },
                    limits::Verdict::Refuse => protocol::error_json("too many commands: at most 20 a second"),
                    limits::Verdict::Disconnect => {
                        let _ = socket.send(Message::Text(protocol::error_json("flooding: disconnected").into())).await;
                        break;
                    }
                };
                if socket.send(Message::Text(reply.into())).await.is_err() {
                    break;
                }
            }
        }
    }
    if let Err(e) = record::write(&app.record_dir, session.recording()) {
        eprintln!("reprise-serve: {e}");
    }
}

/// Runs the server until interrupted.
///
/// # Errors
/// [`ServeError`] when the artifacts do not load or the address cannot be bound.
pub fn serve(args: &Args) -> Result<(), ServeError> {
    if args.max_sessions == 0 || !(args.max_minutes.is_finite() && args.max_minutes > 0.0) {
        return Err(ServeError::Config("need --max-sessions >= 1 and --max-minutes > 0".into()));
    }
    let world = World::load(&args.paths(), Tuning::default())?;
    let game = match &args.game {
        Some(path) => Some(GameFile::read(path, &world.labels).map_err(|e| ServeError::Config(e.to_string()))?),
        None => None,
    };
    let app = Arc::new(App::new(world, args.max_sessions, args.max_minutes, args.record_dir.clone(), game)?);
    let rt = tokio::runtime::Builder::new_multi_thread().enable_all().build()?;
    rt.block_on(async move {
        let listener = tokio::net::TcpListener::bind(args.listen).await?;
        let addr = listener.local_addr()?;
        reprise_stagekit::say_whole(&format!(
            "reprise serve: http://{addr}/ ({} labels; systems {}; {})\n",
            world.labels.len(),
            SYSTEM_IDS.join(", "),
            args.game.as_ref().map_or("no game file".into(), |g| format!("game {}", g.display()))
        ));
        axum::serve(listener, router(app))
            .with_graceful_shutdown(async {
                let _ = tokio::signal::ctrl_c().await;
            })
            .await
    })?;
    Ok(())
}
