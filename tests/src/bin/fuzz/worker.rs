//! The worker process: runs inputs sent by the parent and answers with the outcome. A panic is
//! caught and reported with its message and location; a hang is the parent's business (it
//! kills this process after the time limit), so a stuck input never keeps burning CPU.

use std::io::{self, BufReader, BufWriter, Read, Write};
use std::panic::{self, AssertUnwindSafe};
use std::sync::Mutex;

use crate::targets::Target;

/// Outcome of one input as the worker reports it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Outcome {
    /// A result (summary).
    Ok(String),
    /// One error (its message).
    Err(String),
    /// A panic (message and location).
    Panic(String),
}

impl Outcome {
    fn code(&self) -> u8 {
        match self {
            Outcome::Ok(_) => 0,
            Outcome::Err(_) => 1,
            Outcome::Panic(_) => 2,
        }
    }

    /// The text: summary, error or panic message.
    pub fn text(&self) -> &str {
        match self {
            Outcome::Ok(s) | Outcome::Err(s) | Outcome::Panic(s) => s,
        }
    }
}

/// The last panic's message and location, filled by the panic hook.
static LAST_PANIC: Mutex<Option<String>> = Mutex::new(None);

/// Runs one input in this process, turning a panic into [`Outcome::Panic`].
pub fn run_caught(target: Target, input: &[u8]) -> Outcome {
    match panic::catch_unwind(AssertUnwindSafe(|| target.run(input))) {
        Ok(Ok(summary)) => Outcome::Ok(summary),
        Ok(Err(message)) => Outcome::Err(message),
        Err(payload) => {
            let recorded = LAST_PANIC.lock().map(|mut p| p.take()).unwrap_or(None);
            let message = recorded.unwrap_or_else(|| {
                payload
                    .downcast_ref::<&str>()
                    .map(|s| s.to_string())
                    .or_else(|| payload.downcast_ref::<String>().cloned())
                    .unwrap_or_else(|| "panic with a non-string payload".into())
            });
            Outcome::Panic(message)
        }
    }
}

/// Replaces the default panic output (stderr noise per caught panic) by a record of it.
pub fn install_panic_hook() {
    panic::set_hook(Box::new(|info| {
        let payload = info.payload();
        let message = payload
            .downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| payload.downcast_ref::<String>().cloned())
            .unwrap_or_else(|| "panic with a non-string payload".into());
        let location = info
            .location()
            .map(|l| format!(" at {}:{}", l.file(), l.line()))
            .unwrap_or_default();
        if let Ok(mut last) = LAST_PANIC.lock() {
            *last = Some(format!("panicked: {message}{location}"));
        }
    }));
}

/// Writes one frame: a code byte, a little-endian u32 length, the bytes.
pub fn write_frame(out: &mut impl Write, code: u8, bytes: &[u8]) -> io::Result<()> {
    let len = u32::try_from(bytes.len()).map_err(|_| io::Error::other("frame over 4 GiB"))?;
    out.write_all(&[code])?;
    out.write_all(&len.to_le_bytes())?;
    out.write_all(bytes)?;
    out.flush()
}

/// Reads one frame written by [`write_frame`]; `None` at end of stream.
pub fn read_frame(inp: &mut impl Read) -> io::Result<Option<(u8, Vec<u8>)>> {
    let mut head = [0u8; 5];
    match inp.read_exact(&mut head) {
        Ok(()) => {}
        Err(e) if e.kind() == io::ErrorKind::UnexpectedEof => return Ok(None),
        Err(e) => return Err(e),
    }
    let len = u32::from_le_bytes([head[1], head[2], head[3], head[4]]) as usize;
    let mut bytes = vec![0u8; len];
    inp.read_exact(&mut bytes)?;
    Ok(Some((head[0], bytes)))
}

/// Decodes an outcome frame.
pub fn decode_outcome(code: u8, bytes: &[u8]) -> Outcome {
    let text = String::from_utf8_lossy(bytes).into_owned();
    match code {
        0 => Outcome::Ok(text),
        1 => Outcome::Err(text),
        _ => Outcome::Panic(text),
    }
}

/// The worker's main loop: frames in on stdin, outcomes out on stdout, until stdin closes.
pub fn serve() -> io::Result<()> {
    install_panic_hook();
    let mut inp = BufReader::new(io::stdin().lock());
    let mut out = BufWriter::new(io::stdout().lock());
    while let Some((code, input)) = read_frame(&mut inp)? {
        let target = Target::from_code(code).ok_or_else(|| io::Error::other("unknown target"))?;
        let outcome = run_caught(target, &input);
        write_frame(&mut out, outcome.code(), outcome.text().as_bytes())?;
    }
    Ok(())
}
