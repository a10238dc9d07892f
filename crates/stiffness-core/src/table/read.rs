//! The CSV reader: a header, then chunks of complete lines parsed on every core.
//!
//! Memory is bounded by the output arrays plus two chunks ([`CHUNK_BYTES`]): the file is read a
//! chunk at a time, each chunk's complete lines are split into a few pieces per thread at line
//! boundaries and parsed on the pool straight into the output arrays (each piece into its own
//! part of them, `columns`), while the calling thread reads the next chunk (and hashes, when
//! asked). The result does not depend on the thread count: pieces own consecutive parts, their
//! lines are counted from their own start and made the file's in file order, and the error
//! reported is the first one in file order.

use std::io::Read;
use std::path::{Path, PathBuf};

use rayon::prelude::*;
use sha2::{Digest, Sha256};

use super::error::TableError;
use crate::Cancel;

mod columns;
mod plain_row;

use columns::{Cells, Values};

/// Bytes read per chunk; also the longest line accepted (a measurement row is well under 1 kB).
pub const CHUNK_BYTES: usize = 8 << 20;

/// Pieces smaller than this are not split further (thread start-up would cost more).
const MIN_PIECE_BYTES: usize = 256 << 10;

/// Pieces per thread in a chunk: more than one, so that the thread that reads the next chunk
/// meanwhile takes its share of the parsing when it is done.
const PIECES_PER_THREAD: usize = 4;

/// What the cells of a group of columns become.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum CellKind {
    /// `f64`, parsed by the standard library (shortest round trip of what the writer writes).
    Float,
    /// `i64`.
    Integer,
    /// The index of the label among these (ASCII case-insensitive).
    Label(&'static [&'static str]),
}

/// A group of columns read into one row-major array (e.g. `q1..q7` into an N×7 array).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Group(usize);

#[derive(Debug, Clone)]
struct GroupSpec {
    kind: CellKind,
    /// Header index and message name of every column, in the array's order.
    columns: Vec<(usize, String)>,
}

/// Which header columns to read and into which arrays; columns not named are skipped.
#[derive(Debug, Clone, Default)]
pub struct Layout {
    groups: Vec<GroupSpec>,
}

impl Layout {
    /// An empty layout (reads nothing but still checks every row's field count).
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds a group: the columns at these header indices (with the names messages use), read as
    /// `kind`, into one row-major array of `columns.len()` values per row.
    pub fn group(&mut self, kind: CellKind, columns: Vec<(usize, String)>) -> Group {
        self.groups.push(GroupSpec { kind, columns });
        Group(self.groups.len() - 1)
    }
}

/// The rows read: one array per [`Group`] and the file line of every row.
#[derive(Debug, Clone, PartialEq)]
pub struct Table {
    rows: usize,
    values: Vec<Values>,
    /// (row, line) where the line stops being the previous row's + 1 (after a blank line);
    /// the first entry is row 0.
    breaks: Vec<(usize, u64)>,
    /// SHA-256 of every byte of the file, when the reader was asked for it.
    sha256: Option<[u8; 32]>,
}

impl Table {
    /// SHA-256 of exactly the bytes read (header, rows, blank lines, BOM), when the reader was
    /// opened with [`CsvReader::open_hashing`]: the fingerprint of what the arrays came from,
    /// with no second read of the file (which may have changed meanwhile).
    pub fn sha256(&self) -> Option<[u8; 32]> {
        self.sha256
    }

    /// Rows read.
    pub fn rows(&self) -> usize {
        self.rows
    }

    /// The file line (header = 1) of row `row` (0-based data row).
    pub fn line_of(&self, row: usize) -> u64 {
        let k = self.breaks.partition_point(|&(r, _)| r <= row);
        let (r, line) = self.breaks[k.max(1) - 1];
        line + (row - r) as u64
    }

    /// Takes a [`CellKind::Float`] group's row-major values (empty if taken or of another kind).
    pub fn take_floats(&mut self, group: Group) -> Vec<f64> {
        match &mut self.values[group.0] {
            Values::Float(v) => std::mem::take(v),
            _ => Vec::new(),
        }
    }

    /// Takes a [`CellKind::Integer`] group's row-major values.
    pub fn take_integers(&mut self, group: Group) -> Vec<i64> {
        match &mut self.values[group.0] {
            Values::Integer(v) => std::mem::take(v),
            _ => Vec::new(),
        }
    }

    /// Takes a [`CellKind::Label`] group's label indices.
    pub fn take_labels(&mut self, group: Group) -> Vec<u8> {
        match &mut self.values[group.0] {
            Values::Label(v) => std::mem::take(v),
            _ => Vec::new(),
        }
    }
}

/// A CSV table being read: the header is parsed on opening, the rows by [`CsvReader::read`].
///
/// Dialect: comma-separated, one record per line (`\n` or `\r\n`), a header line first, blank
/// lines skipped (and counted), cells trimmed of ASCII whitespace, `"`-quoted cells allowed
/// (with `""` for a quote) but not spanning lines, a UTF-8 byte-order mark ignored, every row with
/// the header's field count.
///
/// ```
/// use stiffness_core::table::{CellKind, CsvReader, Layout};
/// let text = "x, y ,label\n1.5,2,a\n\n-3e-2,4,B\n";
/// let mut reader = CsvReader::from_reader(text.as_bytes())?;
/// assert_eq!(reader.header(), ["x", "y", "label"]);
/// let mut layout = Layout::new();
/// let xy = layout.group(CellKind::Float, vec![(0, "x".into()), (1, "y".into())]);
/// let label = layout.group(CellKind::Label(&["a", "b"]), vec![(2, "label".into())]);
/// let mut table = reader.read(&layout, &Default::default())?;
/// assert_eq!(table.take_floats(xy), [1.5, 2.0, -0.03, 4.0]);
/// assert_eq!(table.take_labels(label), [0, 1]);
/// assert_eq!((table.line_of(0), table.line_of(1)), (2, 4)); // line 3 is blank
/// # Ok::<(), stiffness_core::table::TableError>(())
/// ```
#[derive(Debug)]
pub struct CsvReader<R> {
    source: R,
    path: PathBuf,
    size: Option<u64>,
    buf: Vec<u8>,
    filled: usize,
    eof: bool,
    /// File line of the first byte of `buf`.
    line: u64,
    /// Bytes consumed before `buf` (for the row estimate).
    consumed: u64,
    header: Vec<String>,
    /// SHA-256 of the bytes consumed so far, when asked for ([`CsvReader::open_hashing`]).
    hasher: Option<Sha256>,
}

impl CsvReader<std::fs::File> {
    /// Opens `path` and reads its header.
    pub fn open(path: impl AsRef<Path>) -> Result<Self, TableError> {
        Self::open_file(path.as_ref(), None)
    }

    /// [`CsvReader::open`], also hashing every byte read ([`Table::sha256`]). The hash of a
    /// chunk is taken while the pool parses it, so it costs little more than the read.
    pub fn open_hashing(path: impl AsRef<Path>) -> Result<Self, TableError> {
        Self::open_file(path.as_ref(), Some(Sha256::new()))
    }

    fn open_file(path: &Path, hasher: Option<Sha256>) -> Result<Self, TableError> {
        let io = |source| TableError::Io {
            path: path.to_path_buf(),
            source,
        };
        let file = std::fs::File::open(path).map_err(io)?;
        let size = file.metadata().map_err(io)?.len();
        Self::start(file, path.to_path_buf(), Some(size), hasher)
    }
}

impl<R: Read> CsvReader<R> {
    /// Reads the header from any reader.
    pub fn from_reader(source: R) -> Result<Self, TableError> {
        Self::start(source, PathBuf::from("<reader>"), None, None)
    }

    fn start(
        source: R,
        path: PathBuf,
        size: Option<u64>,
        hasher: Option<Sha256>,
    ) -> Result<Self, TableError> {
        let mut reader = CsvReader {
            source,
            path,
            size,
            buf: vec![0; CHUNK_BYTES],
            filled: 0,
            eof: false,
            line: 1,
            consumed: 0,
            header: Vec::new(),
            hasher,
        };
        reader.fill()?;
        if reader.buf[..reader.filled].starts_with("\u{feff}".as_bytes()) {
            reader.consume(3, 0);
        }
        // Blank lines before the header are skipped, as between rows.
        loop {
            let data = &reader.buf[..reader.filled];
            let Some(end) = line_end(data, reader.eof) else {
                return Err(TableError::Malformed {
                    line: reader.line,
                    message: format!("the header line is longer than {CHUNK_BYTES} bytes"),
                });
            };
            if end == 0 {
                return Err(TableError::NoHeader);
            }
            let text = utf8(strip_eol(&data[..end]), reader.line)?;
            if is_blank(text.as_bytes()) {
                reader.consume(end, 1);
                continue;
            }
            let mut fields = Vec::new();
            split_fields(text, reader.line, |_, cell| {
                fields.push(cell.into_owned());
                Ok(())
            })?;
            reader.header = fields;
            reader.consume(end, 1);
            return Ok(reader);
        }
    }

    /// The header's names, trimmed and unquoted, as written (not lower-cased).
    pub fn header(&self) -> &[String] {
        &self.header
    }

    /// Tops the buffer up from the source (until full or at end of input).
    fn fill(&mut self) -> Result<(), TableError> {
        fill_buffer(
            &mut self.source,
            &self.path,
            &mut self.buf,
            &mut self.filled,
            &mut self.eof,
        )
    }

    fn consume(&mut self, n: usize, lines: u64) {
        if let Some(h) = &mut self.hasher {
            h.update(&self.buf[..n]);
        }
        self.buf.copy_within(n..self.filled, 0);
        self.filled -= n;
        self.line += lines;
        self.consumed += n as u64;
    }
}

/// The end (after its `\n`) of the first line of `data`; at end of input the whole rest.
impl<R: Read> CsvReader<R> {
    /// Reads every row into the layout's groups; polls `cancel` once per chunk.
    pub fn read(mut self, layout: &Layout, cancel: &Cancel) -> Result<Table, TableError> {
        let width = self.header.len();
        let mut slots: Vec<Option<(usize, usize)>> = vec![None; width];
        for (g, spec) in layout.groups.iter().enumerate() {
            for (offset, &(field, _)) in spec.columns.iter().enumerate() {
                assert!(
                    field < width,
                    "layout names field {field} of a {width}-field header"
                );
                slots[field] = Some((g, offset));
            }
        }
        let plan = Plan {
            width,
            slots,
            groups: &layout.groups,
        };
        let widths: Vec<usize> = layout.groups.iter().map(|g| g.columns.len()).collect();
        let mut table = Table {
            rows: 0,
            values: layout.groups.iter().map(|g| Values::new(g.kind)).collect(),
            breaks: vec![(0, self.line)],
            sha256: None,
        };
        // File line of the next chunk's first line; whether the arrays have been made as long
        // as the rows the file is expected to hold (zeroed by the allocator, once the first
        // chunk's rows are known: `Values::extend_zeroed_to`).
        let mut line = self.line;
        let mut sized = false;
        // Chunk k's pieces are parsed on the pool, straight into the table's arrays, while this
        // thread reads chunk k + 1 into `spare` (and hashes chunk k, when asked): the serial
        // work hides behind the parallel work. Pieces count their lines themselves (relative
        // to their start); `Table::commit`, in file order, makes them the file's.
        let mut spare = vec![0; CHUNK_BYTES];
        self.fill()?;
        loop {
            if cancel.is_cancelled() {
                return Err(TableError::Cancelled);
            }
            let data = &self.buf[..self.filled];
            if data.is_empty() {
                break;
            }
            let end = match data.iter().rposition(|&b| b == b'\n') {
                Some(k) => k + 1,
                None if self.eof => data.len(),
                None => {
                    return Err(TableError::Malformed {
                        line,
                        message: format!("a line longer than {CHUNK_BYTES} bytes"),
                    });
                }
            };
            let pieces = split_pieces(
                &data[..end],
                PIECES_PER_THREAD * rayon::current_num_threads(),
            );
            // Room from the table's current end for as many rows as each piece may hold.
            let rooms: Vec<usize> = pieces.par_iter().map(|p| row_room(p, width)).collect();
            let room = table.rows + rooms.iter().sum::<usize>();
            for (values, &w) in table.values.iter_mut().zip(&widths) {
                values.grow_to(room * w);
            }
            // The incomplete last line starts the next chunk.
            let tail = data.len() - end;
            spare[..tail].copy_from_slice(&data[end..]);
            let (mut spare_filled, mut spare_eof) = (tail, self.eof);
            let mut parsed: Vec<PieceRows> = Vec::new();
            let parts = columns::piece_parts(&mut table.values, &widths, table.rows, &rooms);
            // The source need not be `Send`: it stays on this thread.
            let next = rayon::in_place_scope(|scope| {
                scope.spawn(|_| {
                    parsed = pieces
                        .par_iter()
                        .zip(parts)
                        .map(|(piece, mut cells)| parse_piece(piece, &plan, &mut cells))
                        .collect();
                });
                let next = fill_buffer(
                    &mut self.source,
                    &self.path,
                    &mut spare,
                    &mut spare_filled,
                    &mut spare_eof,
                );
                if let Some(h) = &mut self.hasher {
                    h.update(&data[..end]);
                }
                next
            });
            // Errors in file order: this chunk's, then the read's.
            table.commit(parsed, &rooms, &widths, &mut line)?;
            next?;
            self.consumed += end as u64;
            if let (false, Some(size)) = (sized, self.size) {
                sized = table.rows > 0;
                if sized {
                    let rows = expected_rows_of(size, self.consumed, table.rows);
                    for (values, &w) in table.values.iter_mut().zip(&widths) {
                        values.extend_zeroed_to(rows.saturating_mul(w));
                    }
                }
            }
            std::mem::swap(&mut self.buf, &mut spare);
            self.filled = spare_filled;
            self.eof = spare_eof;
        }
        for (values, &w) in table.values.iter_mut().zip(&widths) {
            values.truncate(table.rows * w);
        }
        table.sha256 = self.hasher.map(|h| h.finalize().into());
        Ok(table)
    }
}

/// Rows a file of `size` bytes is expected to hold, from the `rows` of its first `bytes`
/// (2 % over, for rows a little shorter than the first ones).
fn expected_rows_of(size: u64, bytes: u64, rows: usize) -> usize {
    let per_row = bytes.max(1) as f64 / rows.max(1) as f64;
    (size as f64 / per_row * 1.02).min(usize::MAX as f64 / 16.0) as usize
}

/// The most rows a piece of complete lines can hold: one per line (the last may lack its line
/// end at end of input), and no more than its bytes allow, a row of `width` fields being at
/// least `width` bytes with its line end (so a chunk of blank lines asks for no more room than
/// one of rows would).
fn row_room(piece: &[u8], width: usize) -> usize {
    let lines = memchr::memchr_iter(b'\n', piece).count()
        + usize::from(piece.last().is_some_and(|&b| b != b'\n'));
    lines.min(piece.len() / width.max(1) + 1)
}

impl Table {
    /// Takes one chunk's pieces (piece `j` was given room for `rooms[j]` rows, from the table's
    /// end): closes the gaps their blank lines left, makes their lines the file's, or returns
    /// the first error among them with its file line and row.
    fn commit(
        &mut self,
        pieces: Vec<PieceRows>,
        rooms: &[usize],
        widths: &[usize],
        line: &mut u64,
    ) -> Result<(), TableError> {
        let mut written_at = self.rows;
        for (piece, &room) in pieces.into_iter().zip(rooms) {
            if let Some(e) = piece.error {
                return Err(e.after_lines(*line).after_rows(self.rows));
            }
            if written_at != self.rows {
                for (values, &w) in self.values.iter_mut().zip(widths) {
                    values.move_down(written_at * w, piece.rows * w, self.rows * w);
                }
            }
            for &(row, piece_line) in &piece.breaks {
                let (row, file_line) = (self.rows + row, *line + piece_line);
                let &(r, l) = self.breaks.last().expect("row 0 has a break");
                if row == 0 {
                    self.breaks[0] = (0, file_line);
                } else if l + (row - r) as u64 != file_line {
                    self.breaks.push((row, file_line));
                }
            }
            self.rows += piece.rows;
            *line += piece.lines;
            written_at += room;
        }
        Ok(())
    }
}

/// Reads from `source` into `buf[*filled..]` until it is full or the source ends.
fn fill_buffer(
    source: &mut impl Read,
    path: &Path,
    buf: &mut [u8],
    filled: &mut usize,
    eof: &mut bool,
) -> Result<(), TableError> {
    while !*eof && *filled < buf.len() {
        match source.read(&mut buf[*filled..]) {
            Ok(0) => *eof = true,
            Ok(n) => *filled += n,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(source) => {
                return Err(TableError::Io {
                    path: path.to_path_buf(),
                    source,
                })
            }
        }
    }
    Ok(())
}

fn line_end(data: &[u8], eof: bool) -> Option<usize> {
    match memchr::memchr(b'\n', data) {
        Some(k) => Some(k + 1),
        None if eof => Some(data.len()),
        None => None,
    }
}

/// Splits complete lines into about `parts` pieces at line boundaries.
fn split_pieces(data: &[u8], parts: usize) -> Vec<&[u8]> {
    let parts = parts.clamp(1, (data.len() / MIN_PIECE_BYTES).max(1));
    let mut pieces = Vec::with_capacity(parts);
    let mut start = 0;
    for k in 1..parts {
        let target = (data.len() * k / parts).max(start);
        let Some(nl) = memchr::memchr(b'\n', &data[target..]) else {
            break;
        };
        let end = target + nl + 1;
        pieces.push(&data[start..end]);
        start = end;
    }
    pieces.push(&data[start..]);
    pieces
}

struct Plan<'a> {
    width: usize,
    /// Field → (group, offset in the group's row).
    slots: Vec<Option<(usize, usize)>>,
    groups: &'a [GroupSpec],
}

/// One piece of a chunk, parsed into its part of the table's arrays; lines count from the
/// piece's first line (0), [`Table::commit`] makes them the file's.
struct PieceRows {
    rows: usize,
    /// (row in the piece, line in the piece) of every row whose line is not the previous
    /// row's + 1, and of the piece's first row.
    breaks: Vec<(usize, u64)>,
    /// Lines in the piece, blank ones included.
    lines: u64,
    error: Option<TableError>,
}

fn parse_piece(piece: &[u8], plan: &Plan<'_>, cells: &mut [Cells<'_>]) -> PieceRows {
    let mut out = PieceRows {
        rows: 0,
        breaks: Vec::new(),
        lines: 0,
        error: None,
    };
    if let Err(e) = parse_lines(piece, plan, cells, &mut out) {
        out.error = Some(e);
    }
    out
}

/// Parses a piece's lines into `cells`, which has room for a row per line.
fn parse_lines(
    piece: &[u8],
    plan: &Plan<'_>,
    cells: &mut [Cells<'_>],
    out: &mut PieceRows,
) -> Result<(), TableError> {
    let mut line = 0;
    let mut expected = 0;
    let mut start = 0;
    while start < piece.len() {
        let end = memchr::memchr(b'\n', &piece[start..]).map_or(piece.len(), |k| start + k + 1);
        let bytes = strip_eol(&piece[start..end]);
        start = end;
        if is_blank(bytes) {
            line += 1;
            continue;
        }
        if out.rows == 0 || line != expected {
            out.breaks.push((out.rows, line));
        }
        // A plain row is ASCII where it is not parsed, so it is checked as text only here.
        if plain_row::parse_plain_row(bytes, plan, cells, out.rows) {
            out.rows += 1;
            line += 1;
            expected = line;
            continue;
        }
        let row = utf8(bytes, line)?;
        let mut fields = 0usize;
        split_fields(row, line, |k, cell| {
            fields = k + 1;
            let Some(&Some((g, offset))) = plan.slots.get(k) else {
                return Ok(());
            };
            let spec = &plan.groups[g];
            let column = || spec.columns[offset].1.clone();
            let at = out.rows * spec.columns.len() + offset;
            // The piece's own row: `read` adds the rows of the pieces before it.
            let row = out.rows;
            match &mut cells[g] {
                Cells::Float(v) => {
                    v[at] = cell.parse().map_err(|_| TableError::Parse {
                        line,
                        row,
                        column: column(),
                        text: cell.to_string(),
                        expected: "a number",
                    })?;
                }
                Cells::Integer(v) => {
                    v[at] = cell.parse().map_err(|_| TableError::Parse {
                        line,
                        row,
                        column: column(),
                        text: cell.to_string(),
                        expected: "an integer",
                    })?;
                }
                Cells::Label(v) => {
                    let CellKind::Label(allowed) = spec.kind else {
                        unreachable!("a label group has label values")
                    };
                    let index = allowed
                        .iter()
                        .position(|a| a.eq_ignore_ascii_case(&cell))
                        .ok_or_else(|| TableError::Label {
                            line,
                            row,
                            column: column(),
                            text: cell.to_string(),
                            allowed,
                        })?;
                    v[at] = index as u8;
                }
            }
            Ok(())
        })?;
        if fields != plan.width {
            return Err(TableError::Malformed {
                line,
                message: format!(
                    "found {fields} fields, the header has {} (a missing or extra comma?)",
                    plan.width
                ),
            });
        }
        out.rows += 1;
        line += 1;
        expected = line;
    }
    out.lines = line;
    Ok(())
}

/// Calls `cell(k, text)` for every field of one line (without its line end), trimmed and
/// unquoted.
fn split_fields<'t>(
    row: &'t str,
    line: u64,
    mut cell: impl FnMut(usize, std::borrow::Cow<'t, str>) -> Result<(), TableError>,
) -> Result<(), TableError> {
    let bytes = row.as_bytes();
    // The common line, without quotes: every comma ends a field, found for the whole line at
    // once by memchr's vector search (a byte loop per field, and the general path's scan,
    // trimming and Cow below, were most of the reader's time outside the number parser).
    if memchr::memchr(b'"', bytes).is_none() {
        let mut start = 0;
        for (k, end) in memchr::memchr_iter(b',', bytes)
            .chain(std::iter::once(bytes.len()))
            .enumerate()
        {
            let text = &row[start..end];
            let trimmed = match (text.as_bytes().first(), text.as_bytes().last()) {
                (Some(&a), Some(&b)) if is_space(a as char) || is_space(b as char) => {
                    text.trim_matches(is_space)
                }
                _ => text,
            };
            cell(k, std::borrow::Cow::Borrowed(trimmed))?;
            start = end + 1;
        }
        return Ok(());
    }
    let mut k = 0;
    let mut start = 0;
    loop {
        let rest = &row[start..];
        let lead = rest.len() - rest.trim_start_matches(is_space).len();
        if rest.as_bytes().get(lead) == Some(&b'"') {
            let (text, after) = quoted(&rest[lead..], line)?;
            let tail = &rest[lead + after..];
            let tail_trimmed = tail.trim_start_matches(is_space);
            cell(k, text)?;
            match tail_trimmed.as_bytes().first() {
                None => return Ok(()),
                Some(b',') => {
                    start += lead + after + (tail.len() - tail_trimmed.len()) + 1;
                }
                Some(_) => {
                    return Err(TableError::Malformed {
                        line,
                        message: format!("text after the closing quote of field {}", k + 1),
                    })
                }
            }
        } else {
            let end = memchr::memchr(b',', &bytes[start..]).map_or(row.len(), |e| start + e);
            cell(
                k,
                std::borrow::Cow::Borrowed(row[start..end].trim_matches(is_space)),
            )?;
            if end == row.len() {
                return Ok(());
            }
            start = end + 1;
        }
        k += 1;
    }
}

/// A quoted field at the start of `s`: its text and the byte after the closing quote.
fn quoted(s: &str, line: u64) -> Result<(std::borrow::Cow<'_, str>, usize), TableError> {
    let bytes = s.as_bytes();
    let mut owned: Option<String> = None;
    let mut from = 1;
    let mut k = 1;
    while k < bytes.len() {
        if bytes[k] == b'"' {
            if bytes.get(k + 1) == Some(&b'"') {
                owned.get_or_insert_with(String::new).push_str(&s[from..=k]);
                k += 2;
                from = k;
                continue;
            }
            let text = match owned {
                Some(mut o) => {
                    o.push_str(&s[from..k]);
                    std::borrow::Cow::Owned(o)
                }
                None => std::borrow::Cow::Borrowed(&s[1..k]),
            };
            let trimmed = match text {
                std::borrow::Cow::Borrowed(t) => {
                    std::borrow::Cow::Borrowed(t.trim_matches(is_space))
                }
                std::borrow::Cow::Owned(t) => {
                    std::borrow::Cow::Owned(t.trim_matches(is_space).to_string())
                }
            };
            return Ok((trimmed, k + 1));
        }
        k += 1;
    }
    Err(TableError::Malformed {
        line,
        message: "a quoted field is not closed on its line (a table cell cannot span lines)"
            .to_string(),
    })
}

fn is_space(c: char) -> bool {
    c == ' ' || c == '\t' || c == '\r'
}

fn is_blank(s: &[u8]) -> bool {
    s.iter().all(|&b| b == b' ' || b == b'\t')
}

fn strip_eol(s: &[u8]) -> &[u8] {
    let s = s.strip_suffix(b"\n").unwrap_or(s);
    s.strip_suffix(b"\r").unwrap_or(s)
}

fn utf8(bytes: &[u8], first_line: u64) -> Result<&str, TableError> {
    std::str::from_utf8(bytes).map_err(|e| TableError::Malformed {
        line: first_line + memchr::memchr_iter(b'\n', &bytes[..e.valid_up_to()]).count() as u64,
        message: "not UTF-8 text".to_string(),
    })
}
