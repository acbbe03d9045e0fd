//! The live server under load: `N` sessions at once against a running `reprise serve`
//! on loopback, each with its systems side by side, a TRANSITION every two seconds (each
//! label in turn, sessions staggered), for `SECONDS`. Prints, over the sessions: frames
//! per second (the slowest session's and the median), the gaps between frames (p50, p99,
//! max), a command's wait from sending to the arrival of the frame it is stamped with,
//! and the server's own `GET /stats` (making a frame, tick lateness, command to frame).
//!
//! ```text
//! cargo run --release -p reprise-serve --example load -- ADDR [SESSIONS] [SECONDS] [SYSTEMS]
//! ```
//! `ADDR` must be a loopback address (this sends traffic only to 127.0.0.1 or ::1).
//! `bench/live.sh` runs it with the server and the client on separate cores.

use std::net::SocketAddr;
use std::time::{Duration, Instant};

use futures_util::{SinkExt, StreamExt};
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio_tungstenite::tungstenite::Message;

/// The seconds at the start of each session not measured (connection, first frames).
const WARMUP: f64 = 1.0;

/// What one session saw.
#[derive(Debug, Default)]
struct Seen {
    frames: usize,
    measured_seconds: f64,
    gaps_ms: Vec<f64>,
    command_ms: Vec<f64>,
    errors: Vec<String>,
}

/// `GET path` on loopback `addr`: the body.
async fn get(addr: SocketAddr, path: &str) -> String {
    let mut s = tokio::net::TcpStream::connect(addr).await.expect("the server answers");
    let req = format!("GET {path} HTTP/1.1\r\nHost: {addr}\r\nConnection: close\r\n\r\n");
    s.write_all(req.as_bytes()).await.expect("send");
    let mut out = String::new();
    s.read_to_string(&mut out).await.expect("read");
    out.split_once("\r\n\r\n").map(|(_, b)| b.to_string()).unwrap_or_default()
}

async fn session(
    addr: SocketAddr,
    systems: String,
    labels: Vec<String>,
    starts: Vec<String>,
    index: usize,
    seconds: f64,
) -> Seen {
    // Each session starts in its own label among those every system can start in.
    let start = &starts[index % starts.len()];
    let url = format!("ws://{addr}/session?systems={systems}&start={start}&seed={index}");
    let mut seen = Seen::default();
    let mut ws = match tokio_tungstenite::connect_async(url).await {
        Ok((ws, _)) => ws,
        Err(e) => {
            seen.errors.push(format!("session {index} refused: {e}"));
            return seen;
        }
    };
    let began = Instant::now();
    let end = began + Duration::from_secs_f64(seconds);
    // Staggered so the sessions' commands do not all land on one tick.
    let mut next_command = began + Duration::from_secs_f64(WARMUP + 0.05 * index as f64);
    let mut last_frame_at: Option<Instant> = None;
    let mut sent: Vec<Instant> = Vec::new();
    let mut waiting: Vec<(u64, Instant)> = Vec::new();
    let mut n_commands = 0;
    while Instant::now() < end {
        let wait = next_command.min(end).saturating_duration_since(Instant::now());
        let msg = match tokio::time::timeout(wait, ws.next()).await {
            Err(_) => {
                if Instant::now() >= next_command {
                    n_commands += 1;
                    let to = &labels[(index + n_commands) % labels.len()];
                    let c = format!(r#"{{"type":"transition","to":"{to}"}}"#);
                    ws.send(Message::Text(c.into())).await.expect("send");
                    sent.push(Instant::now());
                    next_command += Duration::from_secs(2);
                }
                continue;
            }
            Ok(Some(Ok(m))) => m,
            Ok(other) => {
                seen.errors.push(format!("session {index} ended: {other:?}"));
                break;
            }
        };
        let now = Instant::now();
        let measured = now.duration_since(began).as_secs_f64() >= WARMUP;
        match msg {
            Message::Binary(b) => {
                let frame = u64::from(u32::from_le_bytes(b[..4].try_into().expect("a frame header")));
                if measured {
                    seen.frames += 1;
                    if let Some(at) = last_frame_at {
                        seen.gaps_ms.push(now.duration_since(at).as_secs_f64() * 1e3);
                    }
                }
                last_frame_at = Some(now);
                waiting.retain(|&(f, at)| {
                    let open = frame < f;
                    if !open {
                        seen.command_ms.push(now.duration_since(at).as_secs_f64() * 1e3);
                    }
                    open
                });
            }
            Message::Text(t) => {
                let v: serde_json::Value = serde_json::from_str(&t).expect("JSON");
                if let Some(f) = v["ok"]["frame"].as_u64().filter(|_| !sent.is_empty()) {
                    waiting.push((f, sent.remove(0)));
                } else if v.get("error").is_some() {
                    seen.errors.push(format!("session {index}: {t}"));
                }
            }
            _ => {}
        }
    }
    seen.measured_seconds = end.duration_since(began).as_secs_f64() - WARMUP;
    let _ = ws.close(None).await;
    seen
}

/// (p50, p99, max) by nearest rank.
fn spread(mut v: Vec<f64>) -> String {
    if v.is_empty() {
        return "-".into();
    }
    v.sort_by(f64::total_cmp);
    let q = |p: f64| v[((p * v.len() as f64).ceil() as usize).max(1) - 1];
    format!("p50 {:.2}  p99 {:.2}  max {:.2}", q(0.5), q(0.99), v[v.len() - 1])
}

#[tokio::main]
async fn main() {
    let args: Vec<String> = std::env::args().collect();
    let usage = "usage: load ADDR [SESSIONS] [SECONDS] [SYSTEMS]";
    let addr: SocketAddr = args.get(1).expect(usage).parse().expect("ADDR is host:port");
    assert!(addr.ip().is_loopback(), "the load test sends traffic only to loopback, not {addr}");
    let n: usize = args.get(2).map_or(1, |s| s.parse().expect("SESSIONS"));
    let seconds: f64 = args.get(3).map_or(20.0, |s| s.parse().expect("SECONDS"));
    let systems = args.get(4).cloned().unwrap_or_else(|| "reprise,motion-graphs,motion-matching,crossfade".into());
    let world: serde_json::Value = serde_json::from_str(&get(addr, "/world").await).expect("GET /world");
    let labels: Vec<String> = serde_json::from_value(world["labels"].clone()).expect("labels");
    let startable: Vec<bool> = serde_json::from_value(world["startable"].clone()).expect("startable");
    let starts: Vec<String> = labels.iter().zip(&startable).filter(|(_, &s)| s).map(|(l, _)| l.clone()).collect();
    assert!(!starts.is_empty(), "no label every system can start in");
    let fps = world["fps"].as_f64().expect("fps");
    let tasks: Vec<_> = (0..n)
        .map(|i| tokio::spawn(session(addr, systems.clone(), labels.clone(), starts.clone(), i, seconds)))
        .collect();
    let mut all = Vec::new();
    for t in tasks {
        all.push(t.await.expect("a session task"));
    }
    let mut rates: Vec<f64> =
        all.iter().map(|s| if s.measured_seconds > 0.0 { s.frames as f64 / s.measured_seconds } else { 0.0 }).collect();
    rates.sort_by(f64::total_cmp);
    let errors: Vec<&String> = all.iter().flat_map(|s| &s.errors).collect();
    println!("{n} session(s) of {systems}, {seconds} s each ({WARMUP} s warm-up unmeasured), corpus at {fps} fps");
    println!(
        "  frames per second: slowest session {:.2}, median {:.2}; sessions below {fps}: {}",
        rates[0],
        rates[rates.len() / 2],
        rates.iter().filter(|&&r| r < fps * 0.99).count()
    );
    println!("  gap between frames (ms): {}", spread(all.iter().flat_map(|s| s.gaps_ms.clone()).collect()));
    println!(
        "  command sent -> its frame received (ms): {}",
        spread(all.iter().flat_map(|s| s.command_ms.clone()).collect())
    );
    println!("  errors: {}", errors.len());
    for e in errors.iter().take(5) {
        println!("    {e}");
    }
    let stats: serde_json::Value = serde_json::from_str(&get(addr, "/stats").await).expect("GET /stats");
    for m in ["frame_make", "tick_late", "command_to_frame"] {
        let s = &stats[m];
        println!(
            "  server {m:<17} (ms): p50 {:.3}  p99 {:.3}  max {:.3}  ({} samples)",
            s["p50_ms"].as_f64().unwrap_or(f64::NAN),
            s["p99_ms"].as_f64().unwrap_or(f64::NAN),
            s["max_ms"].as_f64().unwrap_or(f64::NAN),
            s["count"]
        );
    }
}
