//! Bounded reading of the text inputs that go to recursive parsers: a URDF to urdf-rs (whose
//! XML readers recurse once per nested element and overflow the stack at a few thousand
//! levels) and a model file to serde_json (or Python's `json`, which raises `RecursionError`).
//!
//! Each check is one linear pass over the bytes with a counter, no recursion, so it cannot
//! overflow whatever the input; it runs before the parser sees the text. The limits are far
//! above any real input (a URDF nests fewer than 10 levels, a model file 5) and are documented
//! in `docs/vjm.md` and `docs/model-file.md`.

use std::io::Read;
use std::path::Path;

/// Largest URDF accepted, bytes (real ones are well under 1 MB: meshes are separate files).
pub const URDF_MAX_BYTES: u64 = 16 << 20;
/// Deepest element nesting accepted in a URDF (real ones nest fewer than 10 levels).
pub const URDF_MAX_DEPTH: usize = 256;
/// Largest model file accepted, bytes (a 7-joint extended model is about 100 kB; this admits
/// about 900 parameters with their covariance and null space).
pub const MODEL_FILE_MAX_BYTES: u64 = 64 << 20;
/// Deepest `[`/`{` nesting accepted in a model file (the schema nests 5 levels); below
/// serde_json's own limit of 128, so that limit is never what the user sees.
pub const MODEL_FILE_MAX_DEPTH: usize = 32;

/// A text refused before parsing because it is larger or nests deeper than accepted.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum TextLimitError {
    /// Elements (XML) or arrays/objects (JSON) nest deeper than `limit`.
    #[error(
        "{what} nests {depth} levels deep, more than the {limit} accepted (first passed on \
         line {line})"
    )]
    TooDeep {
        /// `URDF` or `model file`.
        what: &'static str,
        /// The deepest nesting found.
        depth: usize,
        /// The limit.
        limit: usize,
        /// 1-based line where the nesting first passes the limit.
        line: usize,
    },
    /// The text is longer than `limit` bytes.
    #[error("{what} is {}{bytes} bytes, more than the {limit} accepted", if *.at_least { "at least " } else { "" })]
    TooLarge {
        /// `URDF` or `model file`.
        what: &'static str,
        /// Its size (or, read from a stream, how much was read before stopping).
        bytes: u64,
        /// Whether the reading stopped at `bytes` (a stream: the whole is larger).
        at_least: bool,
        /// The limit.
        limit: u64,
    },
}

/// Why a capped read failed.
#[derive(Debug)]
pub(crate) enum CappedReadError {
    /// The file could not be opened or read (or is not UTF-8).
    Io(std::io::Error),
    /// It is larger than the cap.
    TooLarge(TextLimitError),
}

/// Reads `path` as UTF-8 text, refusing more than `limit` bytes without reading them all (a
/// huge file or an endless stream such as `/dev/zero` is not loaded into memory).
pub(crate) fn read_capped(
    path: &Path,
    limit: u64,
    what: &'static str,
) -> Result<String, CappedReadError> {
    let too_large = |bytes: u64, at_least: bool| {
        CappedReadError::TooLarge(TextLimitError::TooLarge {
            what,
            bytes,
            at_least,
            limit,
        })
    };
    let file = std::fs::File::open(path).map_err(CappedReadError::Io)?;
    let size = file
        .metadata()
        .ok()
        .filter(|m| m.is_file())
        .map(|m| m.len());
    if let Some(n) = size.filter(|&n| n > limit) {
        return Err(too_large(n, false));
    }
    let mut bytes = Vec::new();
    file.take(limit + 1)
        .read_to_end(&mut bytes)
        .map_err(CappedReadError::Io)?;
    if bytes.len() as u64 > limit {
        return Err(too_large(bytes.len() as u64, true));
    }
    String::from_utf8(bytes).map_err(|_| {
        CappedReadError::Io(std::io::Error::new(
            std::io::ErrorKind::InvalidData,
            "stream did not contain valid UTF-8",
        ))
    })
}

fn check_size(text: &str, what: &'static str, limit: u64) -> Result<(), TextLimitError> {
    if text.len() as u64 > limit {
        return Err(TextLimitError::TooLarge {
            what,
            bytes: text.len() as u64,
            at_least: false,
            limit,
        });
    }
    Ok(())
}

/// The deepest nesting and the line where it first passed `limit`, tracked by the scanners.
struct Depth {
    now: usize,
    max: usize,
    limit: usize,
    passed_on: Option<usize>,
}

impl Depth {
    fn new(limit: usize) -> Self {
        Depth {
            now: 0,
            max: 0,
            limit,
            passed_on: None,
        }
    }
    fn open(&mut self, line: usize) {
        self.now += 1;
        self.max = self.max.max(self.now);
        if self.now > self.limit && self.passed_on.is_none() {
            self.passed_on = Some(line);
        }
    }
    fn close(&mut self) {
        // A stray closing tag or bracket is the parser's to report; here it only must not wrap.
        self.now = self.now.saturating_sub(1);
    }
    fn result(self, what: &'static str) -> Result<(), TextLimitError> {
        match self.passed_on {
            Some(line) => Err(TextLimitError::TooDeep {
                what,
                depth: self.max,
                limit: self.limit,
                line,
            }),
            None => Ok(()),
        }
    }
}

/// Refuses URDF text above [`URDF_MAX_BYTES`] or with elements nested deeper than
/// [`URDF_MAX_DEPTH`]. Comments, CDATA sections, processing instructions and the DOCTYPE
/// declaration are skipped whole (what they contain is not nesting); quoted attribute values
/// may contain `>` and `/`. Malformed text passes unless it is too deep: the parser reports it.
pub fn check_urdf_text(text: &str) -> Result<(), TextLimitError> {
    check_xml(text, "URDF", URDF_MAX_BYTES, URDF_MAX_DEPTH)
}

fn check_xml(
    text: &str,
    what: &'static str,
    max_bytes: u64,
    max_depth: usize,
) -> Result<(), TextLimitError> {
    check_size(text, what, max_bytes)?;
    let b = text.as_bytes();
    let mut depth = Depth::new(max_depth);
    let mut line = 1;
    let mut i = 0;
    // Moves `i` past the next `pat` (to the end when there is none), counting lines.
    let skip_past = |i: &mut usize, line: &mut usize, pat: &[u8]| {
        let mut j = *i;
        while j < b.len() && !b[j..].starts_with(pat) {
            *line += usize::from(b[j] == b'\n');
            j += 1;
        }
        *i = (j + pat.len()).min(b.len());
    };
    while i < b.len() {
        if b[i] != b'<' {
            line += usize::from(b[i] == b'\n');
            i += 1;
            continue;
        }
        let rest = &b[i..];
        if rest.starts_with(b"<!--") {
            i += 4;
            skip_past(&mut i, &mut line, b"-->");
        } else if rest.starts_with(b"<![CDATA[") {
            i += 9;
            skip_past(&mut i, &mut line, b"]]>");
        } else if rest.starts_with(b"<?") {
            i += 2;
            skip_past(&mut i, &mut line, b"?>");
        } else if rest.starts_with(b"</") {
            depth.close();
            i += 2;
            skip_past(&mut i, &mut line, b">");
        } else {
            // A start tag, or a `<!DOCTYPE …>` declaration whose internal subset `[…]` holds
            // further `<…>` declarations: up to the `>` outside quotes and brackets.
            let declaration = rest.starts_with(b"<!");
            let tag_line = line;
            let (mut quote, mut brackets, mut j) = (None, 0usize, i + 1);
            let mut empty = false;
            while j < b.len() {
                let c = b[j];
                line += usize::from(c == b'\n');
                match quote {
                    Some(q) if c == q => quote = None,
                    Some(_) => {}
                    None => match c {
                        b'"' | b'\'' => quote = Some(c),
                        b'[' if declaration => brackets += 1,
                        b']' if declaration => brackets = brackets.saturating_sub(1),
                        b'>' if brackets == 0 => {
                            empty = b[j - 1] == b'/';
                            break;
                        }
                        _ => {}
                    },
                }
                j += 1;
            }
            if !declaration && !empty {
                depth.open(tag_line);
            }
            i = j + 1;
        }
    }
    depth.result(what)
}

/// Refuses model-file text above [`MODEL_FILE_MAX_BYTES`] or with arrays/objects nested
/// deeper than [`MODEL_FILE_MAX_DEPTH`] (brackets inside strings do not count).
pub fn check_model_file_text(text: &str) -> Result<(), TextLimitError> {
    check_size(text, "model file", MODEL_FILE_MAX_BYTES)?;
    let mut depth = Depth::new(MODEL_FILE_MAX_DEPTH);
    let (mut line, mut in_string, mut escaped) = (1, false, false);
    for &c in text.as_bytes() {
        if c == b'\n' {
            line += 1;
        }
        if in_string {
            match c {
                _ if escaped => escaped = false,
                b'\\' => escaped = true,
                b'"' => in_string = false,
                _ => {}
            }
            continue;
        }
        match c {
            b'"' => in_string = true,
            b'[' | b'{' => depth.open(line),
            b']' | b'}' => depth.close(),
            _ => {}
        }
    }
    depth.result("model file")
}
