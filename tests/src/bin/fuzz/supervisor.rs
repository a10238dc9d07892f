//! The watchdog: a worker process fed one input at a time. An input that does not answer within
//! the time limit is a hang (the worker is killed and replaced); a worker that dies (abort,
//! stack overflow, out of memory) is a crash.

use std::io::{self, BufReader, BufWriter, Write};
use std::process::{Child, ChildStdin, Command, Stdio};
use std::sync::mpsc::{self, Receiver, RecvTimeoutError};
use std::thread;
use std::time::Duration;

use crate::targets::Target;
use crate::worker::{decode_outcome, read_frame, write_frame, Outcome};

/// What happened to one input.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Verdict {
    /// The worker answered in time.
    Done(Outcome),
    /// No answer within the limit (twice, each time on a fresh worker).
    Hang,
    /// The worker process died; the text says how.
    Died(String),
}

/// One frame read from the worker (or why none could be).
type Answer = io::Result<Option<(u8, Vec<u8>)>>;

/// A running worker process.
#[derive(Debug)]
struct Worker {
    child: Child,
    stdin: BufWriter<ChildStdin>,
    answers: Receiver<Answer>,
}

impl Worker {
    fn spawn() -> io::Result<Self> {
        let mut child = Command::new(std::env::current_exe()?)
            .arg("--worker")
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()?;
        let stdin = BufWriter::new(child.stdin.take().expect("piped stdin"));
        let mut stdout = BufReader::new(child.stdout.take().expect("piped stdout"));
        let (tx, answers) = mpsc::channel();
        thread::spawn(move || loop {
            let frame = read_frame(&mut stdout);
            let end = !matches!(frame, Ok(Some(_)));
            if tx.send(frame).is_err() || end {
                break;
            }
        });
        Ok(Worker {
            child,
            stdin,
            answers,
        })
    }

    fn kill(mut self) -> String {
        let _ = self.child.kill();
        match self.child.wait() {
            Ok(status) => status.to_string(),
            Err(e) => e.to_string(),
        }
    }
}

/// Runs inputs in a worker process under a time limit.
#[derive(Debug)]
pub struct Supervisor {
    worker: Option<Worker>,
    timeout: Duration,
}

impl Supervisor {
    /// A supervisor whose inputs must answer within `timeout`.
    pub fn new(timeout: Duration) -> Self {
        Supervisor {
            worker: None,
            timeout,
        }
    }

    /// Runs one input; a timeout is confirmed once on a fresh worker, so a machine busy with
    /// other work does not report a slow input as a hang.
    pub fn run(&mut self, target: Target, input: &[u8]) -> io::Result<Verdict> {
        match self.run_once(target, input)? {
            Verdict::Hang => self.run_once(target, input),
            verdict => Ok(verdict),
        }
    }

    fn run_once(&mut self, target: Target, input: &[u8]) -> io::Result<Verdict> {
        let mut worker = match self.worker.take() {
            Some(w) => w,
            None => Worker::spawn()?,
        };
        if write_frame(&mut worker.stdin, target.code(), input).is_err() {
            return Ok(Verdict::Died(format!(
                "worker died on input: {}",
                worker.kill()
            )));
        }
        match worker.answers.recv_timeout(self.timeout) {
            Ok(Ok(Some((code, bytes)))) => {
                self.worker = Some(worker);
                Ok(Verdict::Done(decode_outcome(code, &bytes)))
            }
            Ok(_) | Err(RecvTimeoutError::Disconnected) => {
                Ok(Verdict::Died(format!("worker died: {}", worker.kill())))
            }
            Err(RecvTimeoutError::Timeout) => {
                worker.kill();
                Ok(Verdict::Hang)
            }
        }
    }
}

impl Drop for Supervisor {
    fn drop(&mut self) {
        if let Some(mut w) = self.worker.take() {
            // Closing stdin ends the worker's loop; kill in case it is stuck.
            let _ = w.stdin.flush();
            w.kill();
        }
    }
}
