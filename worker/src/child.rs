//! Jobs in their own process: a job whose engine aborts its process (an allocation the machine
//! cannot make, which Rust answers by aborting; a stack overflow; a bug) takes down that
//! process only, not the worker and the other jobs it runs. The worker starts its own
//! executable as `sable job-run` for each job ([`crate::PoolConfig::job_process`]), sends it
//! the job on its standard input, reads the samples, snapshots, checkpoints and the end from
//! its standard output, and sends it the requests to cancel and to take a checkpoint. A job
//! process that ends without a result fails its job with code `crashed`, the way it ended in
//! the message; the job is not run again (the same scene would end the same way).
//!
//! Frames, both ways: one byte of kind, four bytes of length (little-endian), the payload. A
//! payload with binary parts starts with a JSON header, itself prefixed by its length.

use std::io::{self, Read, Write};
use std::sync::atomic::Ordering;
use std::sync::{Arc, Mutex};

use serde::{Deserialize, Serialize};
use tokio::io::{AsyncRead, AsyncReadExt, AsyncWriteExt};

use sable_engine::methods::plan_scene;
use sable_engine::observe::Sample;
use sable_engine::run::{Progress, Runner};
use sable_engine::scene::format_violations;

use crate::execute::{apply_thread_budget, engine_run, Ended, Msg};
use crate::source::{CheckpointFile, ResumeFrom, SnapshotFiles};

/// Largest frame read, bytes (a final state or a checkpoint of about two million particles).
const MAX_FRAME: usize = 1 << 30;

/// Parent to child: the job (JSON [`JobInput`]).
const JOB: u8 = b'J';
/// Parent to child: the checkpoint to go on from (gzip bytes).
const CHECKPOINT_IN: u8 = b'C';
/// Parent to child: start.
const GO: u8 = b'G';
/// Parent to child: stop the run.
const CANCEL: u8 = b'c';
/// Parent to child: take a checkpoint.
const TAKE_CHECKPOINT: u8 = b'k';
/// Child to parent: a sample and the progress (JSON [`SampleFrame`]).
const SAMPLE: u8 = b's';
/// Child to parent: a snapshot (header [`SnapshotHeader`], then its three files).
const SNAPSHOT: u8 = b'v';
/// Child to parent: a checkpoint (header [`CheckpointHeader`], then its bytes).
const CHECKPOINT_OUT: u8 = b'K';
/// Child to parent: the lease's checkpoint could not be gone on from (text: why).
const FROM_START: u8 = b'f';
/// Child to parent: the final state (gzip bytes).
const STATE: u8 = b'x';
/// Child to parent: how the run ended (JSON [`Ended`]); the last frame.
const END: u8 = b'e';

/// What a job process is given.
#[derive(Serialize, Deserialize)]
struct JobInput {
    job: i64,
    scene: String,
    threads: usize,
    /// The step of the checkpoint sent next, and the samples before it.
    resume: Option<(u64, Vec<Sample>)>,
    /// Largest data (heap and written mappings) of the process, bytes.
    memory: Option<u64>,
}

#[derive(Serialize, Deserialize)]
struct SampleFrame {
    sample: Sample,
    fraction: f64,
    elapsed: f64,
    remaining: Option<f64>,
}

#[derive(Serialize, Deserialize)]
struct SnapshotHeader {
    index: u32,
    step: u64,
    time: f64,
    sizes: [usize; 3],
}

#[derive(Serialize, Deserialize)]
struct CheckpointHeader {
    step: u64,
    samples: u64,
    snapshots: u64,
}

fn frame(kind: u8, parts: &[&[u8]]) -> Vec<u8> {
    let len: usize = parts.iter().map(|p| p.len()).sum();
    let mut out = Vec::with_capacity(5 + len);
    out.push(kind);
    out.extend_from_slice(&(len as u32).to_le_bytes());
    for p in parts {
        out.extend_from_slice(p);
    }
    out
}

/// A payload of a JSON header and binary parts.
fn with_header(header: &impl Serialize, parts: &[&[u8]]) -> Vec<u8> {
    let h = serde_json::to_vec(header).unwrap_or_default();
    let mut out = Vec::with_capacity(4 + h.len() + parts.iter().map(|p| p.len()).sum::<usize>());
    out.extend_from_slice(&(h.len() as u32).to_le_bytes());
    out.extend_from_slice(&h);
    for p in parts {
        out.extend_from_slice(p);
    }
    out
}

/// Splits a payload made by [`with_header`] into its header and the bytes after it.
fn split_header<T: for<'de> Deserialize<'de>>(payload: &[u8]) -> io::Result<(T, &[u8])> {
    let bad = |why: &str| io::Error::new(io::ErrorKind::InvalidData, why.to_string());
    let len = payload.get(..4).ok_or_else(|| bad("a frame too short for its header"))?;
    let len = u32::from_le_bytes([len[0], len[1], len[2], len[3]]) as usize;
    let header = payload.get(4..4 + len).ok_or_else(|| bad("a header longer than its frame"))?;
    let header = serde_json::from_slice(header).map_err(|e| bad(&format!("a header: {e}")))?;
    Ok((header, &payload[4 + len..]))
}

/// What a frame's header read into `head` says: its kind and an empty payload of its length
/// to read into; None at the end of the stream (`read`: the header's read).
fn frame_head(read: io::Result<()>, head: [u8; 5]) -> io::Result<Option<(u8, Vec<u8>)>> {
    match read {
        Ok(()) => {}
        Err(e) if e.kind() == io::ErrorKind::UnexpectedEof => return Ok(None),
        Err(e) => return Err(e),
    }
    let len = u32::from_le_bytes([head[1], head[2], head[3], head[4]]) as usize;
    if len > MAX_FRAME {
        return Err(io::Error::new(io::ErrorKind::InvalidData, format!("a frame of {len} bytes")));
    }
    Ok(Some((head[0], vec![0; len])))
}

fn read_frame_sync(r: &mut impl Read) -> io::Result<Option<(u8, Vec<u8>)>> {
    let mut head = [0u8; 5];
    let read = r.read_exact(&mut head);
    let Some((kind, mut payload)) = frame_head(read, head)? else { return Ok(None) };
    r.read_exact(&mut payload)?;
    Ok(Some((kind, payload)))
}

async fn read_frame(r: &mut (impl AsyncRead + Unpin)) -> io::Result<Option<(u8, Vec<u8>)>> {
    let mut head = [0u8; 5];
    let read = r.read_exact(&mut head).await.map(|_| ());
    let Some((kind, mut payload)) = frame_head(read, head)? else { return Ok(None) };
    r.read_exact(&mut payload).await?;
    Ok(Some((kind, payload)))
}

/// The body of `sable job-run`: reads one job from standard input, runs it, writes what it
/// produces to standard output. Returns the process's exit code (2: no job was given).
pub fn job_process_main() -> u8 {
    let mut stdin = io::stdin();
    let mut input: Option<JobInput> = None;
    let mut checkpoint = None;
    loop {
        match read_frame_sync(&mut stdin) {
            Ok(Some((JOB, payload))) => input = serde_json::from_slice(&payload).ok(),
            Ok(Some((CHECKPOINT_IN, payload))) => checkpoint = Some(payload),
            Ok(Some((GO, _))) => break,
            Ok(Some(_)) => {}
            Ok(None) | Err(_) => return 2,
        }
    }
    let Some(input) = input else { return 2 };
    if let Some(bytes) = input.memory {
        // Before the engine's threads and allocations, which all count against it. The data
        // limit counts what is written to (heap, anonymous mappings, thread stacks), not the
        // address space the allocator reserves and never touches (glibc reserves 64 MiB per
        // arena), which a bound on the address space (RLIMIT_AS) would count.
        let limit = bytes as nix::sys::resource::rlim_t;
        if let Err(e) = nix::sys::resource::setrlimit(nix::sys::resource::Resource::RLIMIT_DATA, limit, limit) {
            eprintln!("cannot bound the job's memory to {bytes} bytes: {e}; it runs unbounded");
        }
    }
    let out = Arc::new(Mutex::new(io::BufWriter::new(io::stdout())));
    let send_frame = {
        let out = out.clone();
        move |bytes: Vec<u8>| {
            if let Ok(mut w) = out.lock() {
                // The parent gone, nothing is read any more: the cancel flag (set below when
                // standard input closes) stops the run.
                let _ = w.write_all(&bytes).and_then(|_| w.flush());
            }
        }
    };
    let (ended, state) = run_input(input, checkpoint, stdin, &send_frame);
    if let Some(state) = state {
        send_frame(frame(STATE, &[&state]));
    }
    send_frame(frame(END, &[&serde_json::to_vec(&ended).unwrap_or_default()]));
    0
}

/// Runs the job of `input`, its controls read from `stdin` on a thread of their own.
fn run_input(
    input: JobInput,
    checkpoint: Option<Vec<u8>>,
    mut stdin: io::Stdin,
    send_frame: &(dyn Fn(Vec<u8>) + Sync),
) -> (Ended, Option<Vec<u8>>) {
    let mut scene = match plan_scene(&input.scene) {
        Ok(s) => s,
        Err(v) => {
            let message = format!("the stored scene is no longer valid: {}", format_violations(&v));
            return (Ended::Failed { code: "invalid_scene".into(), message, step: Some(0), cpu_seconds: 0.0 }, None);
        }
    };
    let threads = apply_thread_budget(&mut scene, input.threads);
    let resume = match (input.resume, checkpoint) {
        (Some((step, samples)), Some(data)) => Some(ResumeFrom { step, checkpoint: data, samples }),
        _ => None,
    };
    let runner = Runner::for_scene(&scene);
    let (cancel, take) = (runner.cancel.clone(), runner.checkpoint.clone());
    std::thread::spawn(move || loop {
        match read_frame_sync(&mut stdin) {
            Ok(Some((TAKE_CHECKPOINT, _))) => take.store(true, Ordering::SeqCst),
            Ok(Some((CANCEL, _))) => cancel.store(true, Ordering::SeqCst),
            Ok(Some(_)) => {}
            // The worker is gone: stop.
            Ok(None) | Err(_) => {
                cancel.store(true, Ordering::SeqCst);
                return;
            }
        }
    });
    engine_run(input.job, scene, &input.scene, threads, resume, runner, &|msg| send_frame(encode(msg)))
}

/// A message of the engine as a frame to the worker.
fn encode(msg: Msg) -> Vec<u8> {
    match msg {
        Msg::Sample(sample, p) => {
            let f = SampleFrame { sample: *sample, fraction: p.fraction, elapsed: p.elapsed, remaining: p.remaining };
            frame(SAMPLE, &[&serde_json::to_vec(&f).unwrap_or_default()])
        }
        Msg::Snapshot(f) => {
            let h =
                SnapshotHeader { index: f.index, step: f.step, time: f.time, sizes: [f.particles.len(), f.contacts.len(), f.walls.len()] };
            frame(SNAPSHOT, &[&with_header(&h, &[&f.particles, &f.contacts, &f.walls])])
        }
        Msg::Checkpoint(c) => {
            let h = CheckpointHeader { step: c.step, samples: c.samples, snapshots: c.snapshots };
            frame(CHECKPOINT_OUT, &[&with_header(&h, &[&c.data])])
        }
        Msg::FromStart(why) => frame(FROM_START, &[why.as_bytes()]),
    }
}

/// A frame of a job process as a message of the engine; None for the end and the state, and
/// for a frame that cannot be read.
fn decode(kind: u8, payload: &[u8]) -> Option<Msg> {
    match kind {
        SAMPLE => {
            let f: SampleFrame = serde_json::from_slice(payload).ok()?;
            Some(Msg::Sample(Box::new(f.sample), Progress { fraction: f.fraction, elapsed: f.elapsed, remaining: f.remaining }))
        }
        SNAPSHOT => {
            let (h, rest): (SnapshotHeader, _) = split_header(payload).ok()?;
            let [a, b, c] = h.sizes;
            let (particles, rest) = rest.split_at_checked(a)?;
            let (contacts, walls) = rest.split_at_checked(b)?;
            (walls.len() == c).then(|| {
                Msg::Snapshot(SnapshotFiles {
                    index: h.index,
                    step: h.step,
                    time: h.time,
                    particles: particles.to_vec(),
                    contacts: contacts.to_vec(),
                    walls: walls.to_vec(),
                })
            })
        }
        CHECKPOINT_OUT => {
            let (h, data): (CheckpointHeader, _) = split_header(payload).ok()?;
            Some(Msg::Checkpoint(CheckpointFile { step: h.step, samples: h.samples, snapshots: h.snapshots, data: data.to_vec() }))
        }
        FROM_START => Some(Msg::FromStart(String::from_utf8_lossy(payload).into_owned())),
        _ => None,
    }
}

/// Runs a job in a process of `exe` (`exe job-run`; its data bounded to `memory` bytes if
/// given), sending its messages to `send` and the flags' requests to it; how it
/// ended and its final state.
#[allow(clippy::too_many_arguments)]
pub(crate) async fn run_in_process(
    exe: &std::path::Path,
    memory: Option<u64>,
    job: i64,
    scene: &str,
    threads: usize,
    resume: Option<&ResumeFrom>,
    runner: &Runner,
    send: &mut (dyn FnMut(Msg) + Send),
) -> (Ended, Option<Vec<u8>>) {
    let failed = |message: String| (Ended::Failed { code: "crashed".into(), message, step: None, cpu_seconds: 0.0 }, None);
    let mut child = match tokio::process::Command::new(exe)
        .arg("job-run")
        .stdin(std::process::Stdio::piped())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .kill_on_drop(true)
        .spawn()
    {
        Ok(c) => c,
        Err(e) => return failed(format!("cannot start the job's process ({}): {e}", exe.display())),
    };
    let (Some(mut stdin), Some(mut stdout), Some(stderr)) = (child.stdin.take(), child.stdout.take(), child.stderr.take()) else {
        return failed("the job's process has no standard input or output".into());
    };
    let last_words = tokio::spawn(last_words(stderr, job));
    let input = JobInput { job, scene: scene.to_string(), threads, resume: resume.map(|r| (r.step, r.samples.clone())), memory };
    let mut bytes = frame(JOB, &[&serde_json::to_vec(&input).unwrap_or_default()]);
    if let Some(r) = resume {
        bytes.extend(frame(CHECKPOINT_IN, &[&r.checkpoint]));
    }
    bytes.extend(frame(GO, &[]));
    if let Err(e) = stdin.write_all(&bytes).await {
        return failed(format!("cannot send the job to its process: {e}"));
    }
    // The runner's flags, set by the worker, forwarded to the process.
    let (cancel, take) = (runner.cancel.clone(), runner.checkpoint.clone());
    let controls = tokio::spawn(async move {
        let mut cancelled = false;
        loop {
            tokio::time::sleep(std::time::Duration::from_millis(20)).await;
            if take.swap(false, Ordering::SeqCst) && stdin.write_all(&frame(TAKE_CHECKPOINT, &[])).await.is_err() {
                return;
            }
            if !cancelled && cancel.load(Ordering::SeqCst) {
                cancelled = true;
                if stdin.write_all(&frame(CANCEL, &[])).await.is_err() {
                    return;
                }
            }
        }
    });
    let mut state = None;
    let mut ended = None;
    while let Ok(Some((kind, payload))) = read_frame(&mut stdout).await {
        match kind {
            END => {
                ended = serde_json::from_slice(&payload).ok();
                break;
            }
            STATE => state = Some(payload),
            _ => {
                if let Some(msg) = decode(kind, &payload) {
                    send(msg);
                }
            }
        }
    }
    controls.abort();
    let status = child.wait().await;
    let said = last_words.await.unwrap_or_default();
    match ended {
        Some(e) => (e, state),
        None => failed(why_it_crashed(status.map(describe).unwrap_or_else(|e| format!("its status cannot be read: {e}")), &said)),
    }
}

/// Most of a job process's standard error kept for the message of a crash, bytes (its end).
const LAST_WORDS: usize = 2048;

/// Copies what a job process writes to its standard error to the worker's, each line marked
/// with the job; returns the last [`LAST_WORDS`] bytes of it.
async fn last_words(stderr: impl AsyncRead + Unpin, job: i64) -> String {
    use tokio::io::AsyncBufReadExt;
    let mut lines = tokio::io::BufReader::new(stderr);
    let mut kept: Vec<u8> = Vec::new();
    let mut line = Vec::new();
    loop {
        line.clear();
        // At most 64 kB at a time: a longer line comes through in pieces.
        match (&mut lines).take(64 * 1024).read_until(b'\n', &mut line).await {
            Ok(0) | Err(_) => break,
            Ok(_) => {}
        }
        let text = String::from_utf8_lossy(&line);
        // The worker's own standard error gone, the line is only kept.
        let _ = writeln!(io::stderr(), "job {job}: {}", text.trim_end());
        kept.extend_from_slice(&line);
        if kept.len() > 2 * LAST_WORDS {
            kept.drain(..kept.len() - LAST_WORDS);
        }
    }
    let start = kept.len().saturating_sub(LAST_WORDS);
    String::from_utf8_lossy(&kept[start..]).trim().to_string()
}

/// The message of a job whose process ended (`how`, [`describe`]) without a result, after
/// what it last wrote (`said`): an allocation that failed says so (Rust's allocator prints
/// its size before it aborts); a process killed without a word was most likely killed for
/// memory by the kernel, or by an operator.
fn why_it_crashed(how: String, said: &str) -> String {
    let last_line = said.lines().rev().find(|l| !l.trim().is_empty()).unwrap_or("").trim();
    let out_of_memory = ["memory allocation of", "Cannot allocate memory", "os error 12", "failed to spawn thread"];
    if let Some(line) = said.lines().find(|l| out_of_memory.iter().any(|m| l.contains(m))) {
        return format!(
            "the job's process ran out of memory ({how}; it said \"{}\"): lower the scene's particle count, or run fewer jobs per machine",
            line.trim()
        );
    }
    if said.contains("has overflowed its stack") {
        return format!("the job's process overflowed its stack ({how}): a bug in Sable, please report it with the scene");
    }
    if last_line.is_empty() {
        return format!(
            "the job's process ended without a result or a word ({how}): killed from outside, most likely by the kernel for \
             lack of memory (lower the scene's particle count, or run fewer jobs per machine) or by an operator"
        );
    }
    format!("the job's process ended without a result ({how}), its last words: \"{last_line}\": a bug in Sable, please report it with the scene")
}

/// How a process ended, in words.
fn describe(status: std::process::ExitStatus) -> String {
    use std::os::unix::process::ExitStatusExt;
    match (status.code(), status.signal()) {
        (Some(code), _) => format!("exit code {code}"),
        (None, Some(sig)) => {
            let name = nix::sys::signal::Signal::try_from(sig).map_or_else(|_| format!("signal {sig}"), |s| format!("{s}"));
            format!("killed by {name}")
        }
        _ => "ended".into(),
    }
}
