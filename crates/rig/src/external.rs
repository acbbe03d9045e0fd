//! A user's rig engine as a child process speaking Arrow IPC streams.
//!
//! Protocol (documented for users in docs/inputs.md, "Your own rig engine"):
//! - reprise starts the command once and writes an Arrow IPC *stream* to its stdin: a
//!   schema of one non-null Float64 column per rig control (named as the control, in
//!   the controls table's order), then one record batch per request, one row per pose.
//! - The evaluator writes an Arrow IPC stream to its stdout: a schema with one column
//!   `positions` of type FixedSizeList<Float64, 3V>, then, for every request batch and
//!   in order, one batch with the same number of rows: `x0, y0, z0, x1, …` per pose.
//! - reprise ends its stream (and closes stdin) when done; the evaluator then ends its
//!   own stream and exits 0. Anything on stderr is kept and shown in errors.
//! - An evaluator that exits early, answers the wrong shape, or is silent for longer
//!   than the time-out (default 60 s per batch) is an error; a silent one is killed.
//! - The evaluator dies with the stage that started it, however the stage ends
//!   ([`spawn_tied`]): a `kill -9` of the stage or of its runner leaves no evaluator.

use std::io::{BufWriter, Read, Write};
use std::path::Path;
use std::process::{Child, ChildStdin, Command, Stdio};
use std::sync::mpsc::{Receiver, RecvTimeoutError};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use arrow::array::{Array, ArrayRef, FixedSizeListArray, Float64Array, RecordBatch};
use arrow::datatypes::{DataType, Field, Schema, SchemaRef};
use arrow::ipc::reader::StreamReader;
use arrow::ipc::writer::StreamWriter;

use crate::{Rig, RigError};

/// Starts `command` so that the child dies with this process. On Linux the child asks,
/// between fork and exec, for SIGKILL when its parent dies (`PR_SET_PDEATHSIG`), and
/// refuses to start if the parent is already gone. The kernel sends that signal when the
/// *thread* that forked the child ends, so every child is forked by one thread that lives
/// as long as the process. Elsewhere the child is spawned plainly (it then ends when it
/// reads the end of its input).
pub fn spawn_tied(command: Command) -> std::io::Result<Child> {
    type Job = (Command, std::sync::mpsc::Sender<std::io::Result<Child>>);
    static SPAWNER: std::sync::OnceLock<Option<Mutex<std::sync::mpsc::Sender<Job>>>> = std::sync::OnceLock::new();
    let mut command = command;
    tie_to_parent(&mut command);
    let spawner = SPAWNER.get_or_init(|| {
        let (tx, rx) = std::sync::mpsc::channel::<Job>();
        let thread = std::thread::Builder::new().name("child-spawner".into()).spawn(move || {
            for (mut command, reply) in rx {
                let _ = reply.send(command.spawn());
            }
        });
        thread.ok().map(|_| Mutex::new(tx))
    });
    let Some(spawner) = spawner else { return command.spawn() };
    let (reply, answer) = std::sync::mpsc::channel();
    let sent =
        spawner.lock().map_err(|_| std::io::Error::other("the spawner's lock is poisoned"))?.send((command, reply));
    sent.map_err(|_| std::io::Error::other("the spawner thread is gone"))?;
    answer.recv().map_err(|_| std::io::Error::other("the spawner thread is gone"))?
}

/// Arms the parent-death signal in the child (see [`spawn_tied`]).
#[cfg(target_os = "linux")]
#[allow(unsafe_code)]
fn tie_to_parent(command: &mut Command) {
    use std::os::unix::process::CommandExt;
    let parent = std::process::id();
    // SAFETY: the closure runs in the forked child before exec, where only
    // async-signal-safe calls are allowed: it makes two system calls (prctl, getppid) and
    // builds its error from an errno without allocating.
    unsafe {
        command.pre_exec(move || {
            rustix::process::set_parent_process_death_signal(Some(rustix::process::Signal::KILL))?;
            match rustix::process::getppid() {
                Some(p) if p.as_raw_nonzero().get() as u32 == parent => Ok(()),
                _ => Err(rustix::io::Errno::SRCH.into()),
            }
        });
    }
}

#[cfg(not(target_os = "linux"))]
fn tie_to_parent(_: &mut Command) {}

/// How a reply that is not an Arrow IPC stream is named.
const NOT_IPC: &str = "its output is not an Arrow IPC stream";

/// The evaluator's output, its first message's prefix checked: an IPC stream message starts
/// with the continuation marker `FF FF FF FF` (or, in the legacy format, directly) and the
/// length of its metadata. Anything else — text, a log line — is refused at once, quoting
/// its first bytes, instead of being taken as a length of gigabytes and waited for until
/// the time-out.
fn ipc_start(mut out: impl Read) -> Result<impl Read, String> {
    const MAX_METADATA: u32 = 16 << 20;
    let mut head = [0u8; 8];
    let mut got = 0;
    while got < head.len() {
        match out.read(&mut head[got..]) {
            Ok(0) => break,
            Ok(n) => got += n,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return Err(format!("cannot read its output: {e}")),
        }
    }
    let word = |i: usize| u32::from_le_bytes(head[i..i + 4].try_into().expect("4 bytes"));
    let ok = got == 0
        || (got == 8 && word(0) == u32::MAX && word(4) <= MAX_METADATA)
        || (got >= 4 && word(0) <= MAX_METADATA);
    if !ok {
        let shown: String =
            head[..got].iter().map(|&b| if b.is_ascii_graphic() || b == b' ' { b as char } else { '.' }).collect();
        return Err(format!(
            "{NOT_IPC}: it starts with `{shown}` (bytes {:02x?}); an evaluator writes only Arrow IPC to its stdout \
             (logs go to stderr)",
            &head[..got]
        ));
    }
    Ok(std::io::Cursor::new(head[..got].to_vec()).chain(out))
}

/// Column of the response stream.
pub const POSITIONS: &str = "positions";

/// Per-batch time-out unless `REPRISE_RIG_TIMEOUT` (seconds) says otherwise.
const DEFAULT_TIMEOUT: Duration = Duration::from_secs(60);

struct Session {
    child: Child,
    writer: Option<StreamWriter<BufWriter<ChildStdin>>>,
    replies: Receiver<Result<RecordBatch, String>>,
}

/// An external evaluator process.
pub struct ExternalRig {
    command: Vec<String>,
    names: Vec<String>,
    rest: Vec<f64>,
    vertices: usize,
    schema: SchemaRef,
    timeout: Duration,
    session: Mutex<Session>,
    stderr: Arc<Mutex<String>>,
    /// Set by the stderr reader once the evaluator closed its stderr.
    stderr_done: Arc<std::sync::atomic::AtomicBool>,
}

impl ExternalRig {
    /// Starts `command` (program and arguments; run in `base`) and evaluates the rest
    /// pose once to learn the vertex count.
    pub fn spawn(command: &[String], base: &Path, names: Vec<String>, rest: Vec<f64>) -> Result<Self, RigError> {
        let timeout = std::env::var("REPRISE_RIG_TIMEOUT")
            .ok()
            .and_then(|s| s.parse::<f64>().ok())
            .map_or(DEFAULT_TIMEOUT, Duration::from_secs_f64);
        Self::spawn_with_timeout(command, base, names, rest, timeout)
    }

    /// As [`ExternalRig::spawn`] with an explicit per-batch time-out.
    pub fn spawn_with_timeout(
        command: &[String],
        base: &Path,
        names: Vec<String>,
        rest: Vec<f64>,
        timeout: Duration,
    ) -> Result<Self, RigError> {
        let line = command.join(" ");
        let fail = |message: String| RigError::External { command: line.clone(), message };
        let (program, args) = command.split_first().ok_or_else(|| fail("empty command".into()))?;
        let mut process = Command::new(program);
        process.args(args).current_dir(base).stdin(Stdio::piped()).stdout(Stdio::piped()).stderr(Stdio::piped());
        let mut child = spawn_tied(process).map_err(|e| fail(format!("cannot start: {e}")))?;
        let stderr = Arc::new(Mutex::new(String::new()));
        let mut err_pipe = child.stderr.take().expect("stderr is piped");
        let sink = stderr.clone();
        let stderr_done = Arc::new(std::sync::atomic::AtomicBool::new(false));
        let done = stderr_done.clone();
        std::thread::spawn(move || {
            let mut buf = [0u8; 4096];
            while let Ok(n) = err_pipe.read(&mut buf) {
                if n == 0 {
                    break;
                }
                let mut s = sink.lock().expect("stderr buffer lock");
                s.push_str(&String::from_utf8_lossy(&buf[..n]));
                if s.len() > 8192 {
                    let cut = s.len() - 4096;
                    let cut = (cut..s.len()).find(|&i| s.is_char_boundary(i)).unwrap_or(s.len());
                    s.replace_range(..cut, "…");
                }
            }
            done.store(true, std::sync::atomic::Ordering::Release);
        });
        let stdout = child.stdout.take().expect("stdout is piped");
        let (tx, replies) = std::sync::mpsc::channel();
        std::thread::spawn(move || {
            match ipc_start(stdout).and_then(|s| StreamReader::try_new(s, None).map_err(|e| e.to_string())) {
                Err(e) if e.starts_with(NOT_IPC) => {
                    let _ = tx.send(Err(e));
                }
                Err(e) => {
                    let _ = tx.send(Err(format!("{NOT_IPC}: {e}")));
                }
                Ok(reader) => {
                    for batch in reader {
                        if tx.send(batch.map_err(|e| format!("bad Arrow IPC batch: {e}"))).is_err() {
                            break;
                        }
                    }
                }
            }
        });
        let fields: Vec<Field> = names.iter().map(|n| Field::new(n, DataType::Float64, false)).collect();
        let schema: SchemaRef = Arc::new(Schema::new(fields));
        let stdin = BufWriter::new(child.stdin.take().expect("stdin is piped"));
        let writer = StreamWriter::try_new(stdin, &schema).map_err(|e| fail(format!("cannot write to it: {e}")))?;
        let mut rig = Self {
            command: command.to_vec(),
            names,
            rest,
            vertices: 0,
            schema,
            timeout,
            session: Mutex::new(Session { child, writer: Some(writer), replies }),
            stderr,
            stderr_done,
        };
        let reply = rig.exchange(&rig.rest.clone())?;
        rig.vertices = reply.len() / 3;
        if reply.is_empty() || reply.len() % 3 != 0 {
            return Err(rig.error(format!("the rest pose gave {} values, not a positive multiple of 3", reply.len())));
        }
        Ok(rig)
    }

    /// An error about an evaluator that has exited: waits (briefly) until its last words
    /// on stderr have been read, so the message carries them.
    fn exited(&self, message: String) -> RigError {
        for _ in 0..200 {
            if self.stderr_done.load(std::sync::atomic::Ordering::Acquire) {
                break;
            }
            std::thread::sleep(Duration::from_millis(5));
        }
        self.error(message)
    }

    fn error(&self, message: String) -> RigError {
        let stderr = self.stderr.lock().map(|s| s.trim().to_string()).unwrap_or_default();
        let message = if stderr.is_empty() { message } else { format!("{message}; its stderr: {stderr}") };
        RigError::External { command: self.command.join(" "), message }
    }

    /// Sends `poses` and returns the flattened positions of the reply.
    fn exchange(&self, poses: &[f64]) -> Result<Vec<f64>, RigError> {
        let n = self.names.len();
        let rows = poses.len() / n;
        let columns: Vec<ArrayRef> = (0..n)
            .map(|c| Arc::new(Float64Array::from_iter_values((0..rows).map(|r| poses[r * n + c]))) as ArrayRef)
            .collect();
        let batch = RecordBatch::try_new(self.schema.clone(), columns).map_err(|e| self.error(e.to_string()))?;
        let mut session = self.session.lock().map_err(|_| self.error("a previous evaluation panicked".into()))?;
        let sent = session.writer.as_mut().map(|w| w.write(&batch).and_then(|()| Ok(w.get_mut().flush()?)));
        if let Some(Err(e)) = sent {
            let status = session.child.wait().map(|s| s.to_string()).unwrap_or_else(|e| e.to_string());
            return Err(self.exited(format!("it stopped reading before answering ({status}; {e})")));
        }
        let reply = match session.replies.recv_timeout(self.timeout) {
            Ok(Ok(batch)) => batch,
            Ok(Err(message)) => return Err(self.error(message)),
            Err(RecvTimeoutError::Timeout) => {
                let _ = session.child.kill();
                return Err(self.error(format!("no answer within {:.1} s; killed it", self.timeout.as_secs_f64())));
            }
            Err(RecvTimeoutError::Disconnected) => {
                let status = session.child.wait().map(|s| s.to_string()).unwrap_or_else(|e| e.to_string());
                return Err(self.exited(format!("it ended its output before answering ({status})")));
            }
        };
        drop(session);
        let out = self.positions(&reply, rows)?;
        self.check_finite(&out, poses)?;
        Ok(out)
    }

    /// Refuses an answer holding NaN or an infinity, naming the pose (its first controls)
    /// and the vertex: a non-finite mesh would become non-finite scales downstream.
    fn check_finite(&self, out: &[f64], poses: &[f64]) -> Result<(), RigError> {
        let Some(i) = out.iter().position(|v| !v.is_finite()) else { return Ok(()) };
        let (n, width) = (self.names.len(), out.len() / (poses.len() / self.names.len()).max(1));
        let pose = i / width.max(1);
        let shown: Vec<String> = self
            .names
            .iter()
            .zip(&poses[pose * n..(pose + 1) * n])
            .take(6)
            .map(|(name, v)| format!("{name} = {v}"))
            .collect();
        let more = if n > 6 { format!(", … ({n} controls)") } else { String::new() };
        Err(self.error(format!(
            "it answered {} for vertex {} ({}) of a pose ({}{more}); an evaluator must give finite positions \
             for every pose it is sent",
            out[i],
            (i % width.max(1)) / 3,
            ["x", "y", "z"][i % 3],
            shown.join(", ")
        )))
    }

    fn positions(&self, reply: &RecordBatch, rows: usize) -> Result<Vec<f64>, RigError> {
        let column = reply
            .column_by_name(POSITIONS)
            .ok_or_else(|| self.error(format!("its reply has no `{POSITIONS}` column")))?;
        let list = column.as_any().downcast_ref::<FixedSizeListArray>().ok_or_else(|| {
            self.error(format!("`{POSITIONS}` is {}, expected FixedSizeList<Float64, 3V>", column.data_type()))
        })?;
        if list.len() != rows {
            return Err(self.error(format!("it answered {} poses for {rows} sent", list.len())));
        }
        let width = list.value_length() as usize;
        if self.vertices != 0 && width != 3 * self.vertices {
            return Err(self.error(format!(
                "it returned {width} values per pose, expected {} ({} vertices × 3, as for the rest pose)",
                3 * self.vertices,
                self.vertices
            )));
        }
        let values = list
            .values()
            .as_any()
            .downcast_ref::<Float64Array>()
            .ok_or_else(|| self.error("`positions` values are not Float64".into()))?;
        if values.null_count() > 0 {
            return Err(self.error("`positions` holds nulls".into()));
        }
        let offset = list.offset() * width;
        Ok(values.values()[offset..offset + rows * width].to_vec())
    }
}

impl Rig for ExternalRig {
    fn describe(&self) -> String {
        format!("external `{}`", self.command.join(" "))
    }
    fn control_names(&self) -> &[String] {
        &self.names
    }
    fn rest_pose(&self) -> Vec<f64> {
        self.rest.clone()
    }
    fn vertex_count(&self) -> usize {
        self.vertices
    }
    fn triangles(&self) -> &[[u32; 3]] {
        &[]
    }
    fn evaluate_batch(&self, poses: &[f64], out: &mut [f64]) -> Result<(), RigError> {
        let n = self.names.len();
        if n == 0 || !poses.len().is_multiple_of(n) || out.len() != poses.len() / n * 3 * self.vertices {
            return Err(RigError::BatchShape { rig: self.describe(), values: poses.len(), controls: n });
        }
        // Large batches go in chunks so one reply never holds more than ~64 MB.
        let chunk = (8_000_000 / (3 * self.vertices).max(1)).max(1) * n;
        for (p, o) in poses.chunks(chunk).zip(out.chunks_mut(chunk / n * 3 * self.vertices)) {
            o.copy_from_slice(&self.exchange(p)?);
        }
        Ok(())
    }
}

impl Drop for ExternalRig {
    fn drop(&mut self) {
        if let Ok(session) = self.session.get_mut() {
            if let Some(mut w) = session.writer.take() {
                let _ = w.finish();
            }
            // Give the evaluator a moment to exit on end of stream, then make sure.
            for _ in 0..50 {
                if matches!(session.child.try_wait(), Ok(Some(_))) {
                    return;
                }
                std::thread::sleep(Duration::from_millis(10));
            }
            let _ = session.child.kill();
            let _ = session.child.wait();
        }
    }
}
