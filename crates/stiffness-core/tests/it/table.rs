//! The table reader and writer: the dialect, the blame (line, column), chunk and thread
//! independence, and the round trip of every float bit pattern class.

use proptest::prelude::*;
use stiffness_core::table::{write_csv, CellKind, Column, CsvReader, Layout, TableError};
use stiffness_core::Cancel;

fn floats(text: &str, n: usize) -> Result<(Vec<f64>, Vec<u64>), TableError> {
    let reader = CsvReader::from_reader(text.as_bytes())?;
    let mut layout = Layout::new();
    let g = layout.group(
        CellKind::Float,
        (0..n).map(|k| (k, format!("c{k}"))).collect(),
    );
    let mut table = reader.read(&layout, &Cancel::new())?;
    let lines = (0..table.rows()).map(|r| table.line_of(r)).collect();
    Ok((table.take_floats(g), lines))
}

#[test]
fn quoted_trimmed_crlf_and_bom_cells_read_as_their_numbers() {
    let text = "\u{feff}a , \"b\"\r\n 1.5 ,\"2e-3\"\r\n\" -4 \", 5\r\n";
    let (v, lines) = floats(text, 2).unwrap();
    assert_eq!(v, [1.5, 2e-3, -4.0, 5.0]);
    assert_eq!(lines, [2, 3]);
}

/// Lines without quotes take the reader's fast split: spaces and tabs around a cell are
/// trimmed, an empty cell is a field of its own (an empty number cell is an error naming it),
/// and a line with a quoted cell among bare ones reads the same.
#[test]
fn unquoted_lines_split_as_quoted_ones() {
    let text = "a,b,c\n 1.5,\t-2 ,3e2\n\"4\", 5 ,6\n7,8,9\t\n";
    let (v, lines) = floats(text, 3).unwrap();
    assert_eq!(v, [1.5, -2.0, 300.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0]);
    assert_eq!(lines, [2, 3, 4]);
    match floats("a,b,c\n1,,3\n", 3) {
        Err(TableError::Parse {
            line: 2,
            column,
            text,
            ..
        }) => assert_eq!((column.as_str(), text.as_str()), ("c1", "")),
        other => panic!("expected the empty cell c1 on line 2, got {other:?}"),
    }
    // One field too many or too few, quoted or not, is the same error.
    for bad in ["a,b\n1,2,3\n", "a,b\n\"1\",2,3\n", "a,b\n1\n"] {
        assert!(
            matches!(floats(bad, 2), Err(TableError::Malformed { line: 2, .. })),
            "{bad:?}"
        );
    }
}

#[test]
fn blank_lines_are_skipped_and_rows_keep_their_file_lines() {
    let (v, lines) = floats("x\n\n1\n2\n\n \n3\n\n", 1).unwrap();
    assert_eq!(v, [1.0, 2.0, 3.0]);
    assert_eq!(lines, [3, 4, 7]);
}

#[test]
fn a_bad_cell_is_named_by_line_and_column() {
    match floats("a,b\n1,2\n\n3,x\n", 2) {
        Err(TableError::Parse {
            line: 4,
            row: 1,
            column,
            text,
            ..
        }) => {
            assert_eq!((column.as_str(), text.as_str()), ("c1", "x"));
        }
        other => panic!("expected a parse error on line 4, got {other:?}"),
    }
}

#[test]
fn a_row_with_a_missing_field_is_malformed_at_its_line() {
    assert!(matches!(
        floats("a,b\n1,2\n3\n", 2),
        Err(TableError::Malformed { line: 3, .. })
    ));
    assert!(matches!(
        floats("a,b\n1,\"2\n", 2),
        Err(TableError::Malformed { line: 2, .. })
    ));
    assert!(matches!(floats("", 1), Err(TableError::NoHeader)));
    assert!(matches!(floats("\n \n", 1), Err(TableError::NoHeader)));
}

/// Bytes that are not UTF-8 are refused on their own line, in a cell that is read or in one
/// that is skipped (the fast path does not check a row as text, so this is its check), and an
/// earlier row's error still comes first.
#[test]
fn a_row_that_is_not_text_is_named_by_its_line() {
    let read = |bytes: &[u8]| {
        let reader = CsvReader::from_reader(bytes).unwrap();
        let mut layout = Layout::new();
        layout.group(CellKind::Float, vec![(0, "x".into())]);
        reader.read(&layout, &Cancel::new())
    };
    for (bytes, at) in [
        (&b"x,note\n1,ok\n2,\xffbad\n3,ok\n"[..], 3),
        (&b"x,note\n1,ok\n\n2\xff,ok\n"[..], 4),
        (&b"x,note\n1,\xc3\n"[..], 2),
    ] {
        match read(bytes) {
            Err(TableError::Malformed { line, message }) => {
                assert_eq!(line, at, "{bytes:?}");
                assert!(message.contains("UTF-8"), "{message}");
            }
            other => panic!("{bytes:?}: expected not UTF-8 on line {at}, got {other:?}"),
        }
    }
    assert!(matches!(
        read(b"x,note\n1,ok\nz,ok\n2,\xff\n"),
        Err(TableError::Parse { line: 3, .. })
    ));
    // Text that is UTF-8 but not ASCII reads, in a skipped cell as in a quoted one.
    let t = read("x,note\n1,caf\u{e9}\n2,\"\u{b5}m\"\n".as_bytes()).unwrap();
    assert_eq!(t.rows(), 2);
}

#[test]
fn a_label_outside_its_list_is_named() {
    let reader = CsvReader::from_reader("set\ntrain\nTEST\nvalidation\n".as_bytes()).unwrap();
    let mut layout = Layout::new();
    layout.group(CellKind::Label(&["train", "test"]), vec![(0, "set".into())]);
    match reader.read(&layout, &Cancel::new()) {
        Err(TableError::Label { line: 4, text, .. }) => assert_eq!(text, "validation"),
        other => panic!("expected an unknown label on line 4, got {other:?}"),
    }
}

#[test]
fn a_cancelled_read_returns_nothing() {
    let cancel = Cancel::new();
    cancel.cancel();
    let reader = CsvReader::from_reader("x\n1\n".as_bytes()).unwrap();
    assert!(matches!(
        reader.read(&Layout::new(), &cancel),
        Err(TableError::Cancelled)
    ));
}

/// A table of ~20 MB: it spans several chunks and pieces, so lines are cut by chunk
/// boundaries. Row i is `i, x_i, -7 x_i` with a blank line after rows 0, 99 991, ...; with
/// `bad_row` that row's `y` is not a number.
fn big_table(bad_row: Option<usize>) -> (String, usize) {
    let rows = 400_000;
    let mut text = String::from("i,x,y\n");
    for i in 0..rows {
        let x = (i as f64).sqrt() * 1e-3 - 0.3;
        if Some(i) == bad_row {
            text.push_str(&format!("{i},{x:?},oops\n"));
        } else {
            text.push_str(&format!("{i},{x:?},{}\n", -x * 7.0));
        }
        if i % 99_991 == 0 {
            text.push('\n'); // a blank line every so often
        }
    }
    assert!(text.len() > 2 * stiffness_core::table::read::CHUNK_BYTES);
    (text, rows)
}

/// Row i's file line: i + 2 plus one blank line after each row 0, 99 991, ... before it.
fn big_table_line(i: usize) -> u64 {
    i as u64 + 2 + i.div_ceil(99_991) as u64
}

fn on_threads<T: Send>(threads: usize, f: impl FnOnce() -> T + Send) -> T {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap()
        .install(f)
}

/// The values and the line numbers must not depend on where the chunk and piece cuts fall or
/// on the number of threads.
#[test]
fn a_table_larger_than_a_chunk_reads_the_same_on_one_thread_and_on_all() {
    let (text, rows) = big_table(None);
    let read = || {
        let reader = CsvReader::from_reader(text.as_bytes()).unwrap();
        let mut layout = Layout::new();
        let i = layout.group(CellKind::Integer, vec![(0, "i".into())]);
        let xy = layout.group(CellKind::Float, vec![(1, "x".into()), (2, "y".into())]);
        let mut t = reader.read(&layout, &Cancel::new()).unwrap();
        let lines: Vec<u64> = (0..t.rows()).map(|r| t.line_of(r)).collect();
        (t.take_integers(i), t.take_floats(xy), lines)
    };
    let one = on_threads(1, read);
    let all = on_threads(4, read);
    assert_eq!(one, all);
    let (ids, xy, lines) = one;
    assert_eq!(ids, (0..rows as i64).collect::<Vec<_>>());
    for i in [0usize, 1, 99_991, 200_000, rows - 1] {
        let x = (i as f64).sqrt() * 1e-3 - 0.3;
        assert_eq!((xy[2 * i], xy[2 * i + 1]), (x, -x * 7.0));
        assert_eq!(lines[i], big_table_line(i), "row {i}");
    }
}

/// A bad cell deep in the file (past the first chunk, in a later piece) is blamed on its own
/// data row and file line, whatever the thread count.
#[test]
fn a_bad_cell_past_the_first_chunk_is_named_by_its_row_and_line() {
    for bad in [1usize, 250_001, 399_999] {
        let (text, _) = big_table(Some(bad));
        for threads in [1, 4] {
            let got = on_threads(threads, || {
                let reader = CsvReader::from_reader(text.as_bytes()).unwrap();
                let mut layout = Layout::new();
                layout.group(
                    CellKind::Float,
                    vec![(0, "i".into()), (1, "x".into()), (2, "y".into())],
                );
                reader.read(&layout, &Cancel::new())
            });
            match got {
                Err(TableError::Parse {
                    row, line, column, ..
                }) => {
                    assert_eq!((row, line), (bad, big_table_line(bad)), "{threads} threads");
                    assert_eq!(column, "y");
                }
                other => panic!("expected a parse error at row {bad}, got {other:?}"),
            }
        }
    }
}

#[test]
fn the_writer_refuses_columns_that_do_not_fit() {
    let mut out = Vec::new();
    let bad = write_csv(
        &mut out,
        &["a", "b"],
        &[Column::Floats {
            data: &[1.0, 2.0, 3.0],
            width: 2,
        }],
        &Cancel::new(),
    );
    assert!(matches!(bad, Err(TableError::Shape { .. })));
    assert!(out.is_empty(), "nothing is written before the check");
}

/// Cells of every length a number can take (3 to 24 bytes for an f64, 1 to 20 for an i64),
/// empty cells, booleans and labels side by side come out as the formatters wrote them: the
/// writer copies a cell with overlapping fixed-length moves, and a wrong offset would cut or
/// smear one.
#[test]
fn cells_of_every_length_are_written_whole() {
    let mut floats: Vec<f64> = vec![
        0.0,
        -0.0,
        1.0,
        12.5,
        123.25,
        12345.25,
        0.123456789,
        5e-324,
        -2.2250738585072014e-308,
        f64::MAX,
        f64::NAN,
    ];
    // 0.1, -0.12, 0.123, …: every length from 3 to 20 bytes.
    for d in 1..=16 {
        let digits = &"1234567891234567"[..d];
        floats.push(format!("0.{digits}").parse().unwrap());
        floats.push(format!("-0.{digits}").parse().unwrap());
    }
    let mut x = -1.0f64;
    for k in 0..40 {
        floats.push(x);
        x = x * -3.7 + 1e-3 * k as f64;
        floats.push(1.0 / x);
    }
    let rows = floats.len();
    let int_cells: Vec<i64> = (0..19)
        .map(|k| 10i64.pow(k) - 1)
        .chain([i64::MIN, i64::MAX, -1, 0, 7])
        .collect();
    let ints: Vec<i64> = (0..rows).map(|i| int_cells[i % int_cells.len()]).collect();
    let (floats, ints) = (&floats[..], &ints[..]);
    let flags: Vec<bool> = (0..rows).map(|i| i % 3 == 0).collect();
    let codes: Vec<u8> = (0..rows).map(|i| (i % 2) as u8).collect();
    let names = ["a", "longer_label"];
    let mut out = Vec::new();
    write_csv(
        &mut out,
        &["f", "i", "ok", "label"],
        &[
            Column::Floats {
                data: floats,
                width: 1,
            },
            Column::Integers {
                data: ints,
                width: 1,
                empty: Some(-1),
            },
            Column::Bools(&flags),
            Column::Labels {
                codes: &codes,
                names: &names,
            },
        ],
        &Cancel::new(),
    )
    .unwrap();
    let mut expected = String::from("f,i,ok,label\n");
    let (mut float_lengths, mut int_lengths) = (Vec::new(), Vec::new());
    for i in 0..rows {
        let f = if floats[i].is_finite() {
            zmij::Buffer::new().format_finite(floats[i]).to_string()
        } else {
            String::new()
        };
        let n = if ints[i] == -1 {
            String::new()
        } else {
            ints[i].to_string()
        };
        float_lengths.push(f.len());
        int_lengths.push(n.len());
        expected += &format!("{f},{n},{},{}\n", flags[i], names[codes[i] as usize]);
    }
    assert_eq!(String::from_utf8(out).unwrap(), expected);
    for len in [3, 4, 6, 8, 9, 15, 16, 17, 23, 24] {
        assert!(
            float_lengths.contains(&len),
            "no float cell of {len} bytes in {float_lengths:?}"
        );
    }
    for len in [0, 1, 2, 4, 8, 15, 16, 19, 20] {
        assert!(
            int_lengths.contains(&len),
            "no integer cell of {len} bytes in {int_lengths:?}"
        );
    }
}

proptest! {
    /// Whatever the bits (subnormals, extremes, negative zero), a written number reads back
    /// exactly; non-finite values become empty cells.
    #[test]
    fn every_finite_float_reads_back_bit_for_bit(bits in proptest::collection::vec(any::<u64>(), 1..200)) {
        let values: Vec<f64> = bits.iter().map(|&b| f64::from_bits(b)).filter(|v| v.is_finite()).collect();
        prop_assume!(!values.is_empty());
        let mut out = Vec::new();
        write_csv(&mut out, &["v"], &[Column::Floats { data: &values, width: 1 }], &Cancel::new()).unwrap();
        let (back, _) = floats(std::str::from_utf8(&out).unwrap(), 1).unwrap();
        prop_assert_eq!(back.iter().map(|v| v.to_bits()).collect::<Vec<_>>(), values.iter().map(|v| v.to_bits()).collect::<Vec<_>>());
    }
}

/// A source that fails after `ok` bytes (a disk or network error mid-file).
struct FailingAfter<'a> {
    text: &'a [u8],
    ok: usize,
}

impl std::io::Read for FailingAfter<'_> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        if self.ok == 0 {
            return Err(std::io::Error::other("the disk went away"));
        }
        let n = buf.len().min(self.ok).min(self.text.len());
        buf[..n].copy_from_slice(&self.text[..n]);
        self.text = &self.text[n..];
        self.ok -= n;
        Ok(n)
    }
}

/// The next chunk is read while this one is parsed: a read error is reported as such, but a
/// bad cell before the failure point is reported first (errors in file order).
#[test]
fn a_read_error_mid_file_comes_after_the_bad_cells_before_it() {
    let fail_at = stiffness_core::table::read::CHUNK_BYTES + 4096;
    for (bad, expect_parse) in [(None, false), (Some(7usize), true), (Some(399_999), false)] {
        let (text, _) = big_table(bad);
        let source = FailingAfter {
            text: text.as_bytes(),
            ok: fail_at,
        };
        let reader = CsvReader::from_reader(source).unwrap();
        let mut layout = Layout::new();
        layout.group(
            CellKind::Float,
            vec![(0, "i".into()), (1, "x".into()), (2, "y".into())],
        );
        match (reader.read(&layout, &Cancel::new()), expect_parse) {
            (Err(TableError::Parse { row, .. }), true) => assert_eq!(Some(row), bad),
            (Err(TableError::Io { source, .. }), false) => {
                assert_eq!(source.to_string(), "the disk went away")
            }
            (other, _) => panic!("bad row {bad:?}: unexpected {other:?}"),
        }
    }
}

/// The hash of a read is the SHA-256 of the whole file (BOM, blank lines, CRLF and a last
/// line without its end included), taken in one pass over a buffer in memory here.
#[test]
fn a_hashing_read_fingerprints_every_byte_of_the_file() {
    use sha2::{Digest, Sha256};
    let (big, _) = big_table(Some(399_999));
    let big = big.replace(",oops", ",1.5");
    let small = "\u{feff}\r\n  x,y\r\n1,2\r\n\r\n3,4".to_string();
    // A fresh folder of this test's own (create_dir fails on one that exists): the files and
    // the folder removed below are only those it wrote.
    let nanos = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .unwrap()
        .as_nanos();
    let dir = std::env::temp_dir().join(format!("table-hash-{}-{nanos}", std::process::id()));
    std::fs::create_dir(&dir).unwrap();
    for (k, text) in [big, small].iter().enumerate() {
        let path = dir.join(format!("t{k}.csv"));
        std::fs::write(&path, text).unwrap();
        let reader = CsvReader::open_hashing(&path).unwrap();
        let mut layout = Layout::new();
        layout.group(CellKind::Float, vec![(0, "x".into())]);
        let table = reader.read(&layout, &Cancel::new()).unwrap();
        let expected: [u8; 32] = Sha256::digest(text.as_bytes()).into();
        assert_eq!(table.sha256(), Some(expected), "file {k}");
        std::fs::remove_file(&path).unwrap();
    }
    std::fs::remove_dir(&dir).unwrap();
}

/// Cells a measurement file may hold, and cells it should not: decimals of every shape (signs,
/// a bare point, exponents, mantissas longer than 19 digits, overflow and underflow), `f64`
/// written shortest and in scientific form, words, padding, quotes, and junk.
fn cell() -> impl Strategy<Value = String> {
    let decimal = "[-+]?[0-9]{0,24}(\\.[0-9]{0,24})?([eE][-+]?[0-9]{0,4})?";
    let padded = ("[ \t]{0,2}", decimal, "[ \t]{0,2}").prop_map(|(a, d, b)| format!("{a}{d}{b}"));
    prop_oneof![
        4 => decimal,
        2 => any::<f64>().prop_map(|v| format!("{v}")),
        2 => any::<f64>().prop_map(|v| format!("{v:e}")),
        1 => padded,
        1 => "[-+]?(inf|Inf|INF|infinity|Infinity|nan|NaN)",
        1 => proptest::sample::select(vec!["\"2.5\"", "\" -1e3 \"", "1_0", "0x1p3", "1.5.2", "1e", "--1", "."])
            .prop_map(str::to_string),
        1 => "[-+.eE0-9a-z_ ]{0,6}",
    ]
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 2048, ..ProptestConfig::default() })]

    /// Whichever path reads a row (the one-pass path of plain rows or the general one), a
    /// number cell is what std's `f64::from_str` makes of it, trimmed of spaces and tabs and
    /// unquoted, bit for bit; a cell std refuses is the error, named by its column.
    #[test]
    fn a_number_cell_reads_as_std_parses_it(cells in proptest::collection::vec(cell(), 3)) {
        let text = format!("a,b,c\n{}\n", cells.join(","));
        let expected: Vec<Result<f64, ()>> = cells
            .iter()
            .map(|c| {
                let c = c.trim_matches([' ', '\t']);
                let c = c.strip_prefix('"').and_then(|c| c.strip_suffix('"')).unwrap_or(c);
                c.trim_matches([' ', '\t']).parse::<f64>().map_err(|_| ())
            })
            .collect();
        match (floats(&text, 3), expected.iter().position(Result::is_err)) {
            (Ok((values, _)), None) => {
                let want: Vec<u64> = expected.iter().map(|v| v.unwrap().to_bits()).collect();
                let got: Vec<u64> = values.iter().map(|v| v.to_bits()).collect();
                prop_assert_eq!(got, want, "{:?}", cells);
            }
            (Err(TableError::Parse { line: 2, column, .. }), Some(k)) => {
                prop_assert_eq!(column, format!("c{k}"), "{:?}", cells);
            }
            (got, first_bad) => prop_assert!(false, "{:?}: read {:?}, std refuses cell {:?}", cells, got, first_bad),
        }
    }
}

/// Row `i` of a table whose first chunk does not look like the rest: rows 0..`long` have their
/// `i` padded with zeros to 200 digits (the arrays' first size, taken from the first chunk's
/// lines, is then far too short), and `blank` blank lines follow the header (then far too long).
fn uneven_table(rows: usize, long: usize, blank: usize) -> String {
    let mut text = String::from("i,x\n");
    text.push_str(&"\n".repeat(blank));
    for i in 0..rows {
        let x = (i as f64).ln_1p() - 4.0;
        if i < long {
            text.push_str(&format!("{i:0>200},{x:?}\n"));
        } else {
            text.push_str(&format!("{i},{x:?}\n"));
        }
    }
    text
}

/// Integers of column 0, floats of column 1 and the line of every row.
fn ints_floats_lines<R: std::io::Read>(reader: CsvReader<R>) -> (Vec<i64>, Vec<f64>, Vec<u64>) {
    let mut layout = Layout::new();
    let i = layout.group(CellKind::Integer, vec![(0, "i".into())]);
    let x = layout.group(CellKind::Float, vec![(1, "x".into())]);
    let mut t = reader.read(&layout, &Cancel::new()).unwrap();
    let lines: Vec<u64> = (0..t.rows()).map(|r| t.line_of(r)).collect();
    (t.take_integers(i), t.take_floats(x), lines)
}

/// A file is read from its path with arrays that reserve what its first chunk predicts: whether
/// that guess is right, far too short (long first rows) or absent (a first chunk of blank
/// lines), every row of every table reads as the same bytes read from memory do, with its own
/// values and line.
#[test]
fn a_file_reads_every_row_however_its_first_chunk_predicts_the_rest() {
    let nanos = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .unwrap()
        .as_nanos();
    let dir = std::env::temp_dir().join(format!("table-size-{}-{nanos}", std::process::id()));
    std::fs::create_dir(&dir).unwrap();
    let chunk = stiffness_core::table::read::CHUNK_BYTES;
    let (big, big_rows) = big_table(None);
    let tables = [
        ("even", big, big_rows, 0usize),
        (
            "long first rows",
            uneven_table(300_000, chunk / 200 + 1, 0),
            300_000,
            0,
        ),
        (
            "blank first chunk",
            uneven_table(300_000, 0, chunk + 5),
            300_000,
            chunk + 5,
        ),
    ];
    for (name, text, rows, blank) in tables {
        let path = dir.join("t.csv");
        std::fs::write(&path, &text).unwrap();
        let from_file = ints_floats_lines(CsvReader::open(&path).unwrap());
        std::fs::remove_file(&path).unwrap();
        let from_memory = ints_floats_lines(CsvReader::from_reader(text.as_bytes()).unwrap());
        assert!(from_file == from_memory, "{name}: the file reads otherwise");
        let (ids, xs, lines) = from_file;
        assert_eq!(ids, (0..rows as i64).collect::<Vec<_>>(), "{name}");
        if name != "even" {
            for (i, &x) in xs.iter().enumerate() {
                assert_eq!(x, (i as f64).ln_1p() - 4.0, "{name}: row {i}");
                assert_eq!(lines[i], (i + 2 + blank) as u64, "{name}: row {i}");
            }
        }
    }
    std::fs::remove_dir(&dir).unwrap();
}

/// A file whose size promises far more rows than it holds (a sparse file: a header, a first
/// chunk of blank lines or of short rows, then a hole of 64 GiB read as NUL bytes) is an error
/// naming the first line of the hole, not an allocation of hundreds of GB that aborts the
/// process (the arrays take a zeroed allocation only if the allocator grants it, and only
/// from rows seen).
#[test]
fn a_sparse_file_is_an_error_not_an_abort() {
    let nanos = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .unwrap()
        .as_nanos();
    let dir = std::env::temp_dir().join(format!("table-sparse-{}-{nanos}", std::process::id()));
    std::fs::create_dir(&dir).unwrap();
    let chunk = stiffness_core::table::read::CHUNK_BYTES;
    let blank = format!("a,b,c\n{}", "\n".repeat(chunk + 7));
    let short = format!("a,b,c\n{}", "1,2,3\n".repeat(chunk / 6 + 7));
    for (name, head, first_hole_line) in [
        ("blank lines", blank, chunk as u64 + 9),
        ("short rows", short, (chunk / 6) as u64 + 9),
    ] {
        let path = dir.join("sparse.csv");
        std::fs::write(&path, &head).unwrap();
        let file = std::fs::OpenOptions::new().write(true).open(&path).unwrap();
        if let Err(e) = file.set_len(64 << 30) {
            // A file system without sparse files cannot make the case; nothing to test.
            eprintln!("skipped ({name}): no sparse file here: {e}");
            std::fs::remove_file(&path).unwrap();
            continue;
        }
        drop(file);
        let mut layout = Layout::new();
        layout.group(CellKind::Float, vec![(0, "a".into())]);
        let got = CsvReader::open(&path)
            .unwrap()
            .read(&layout, &Cancel::new());
        std::fs::remove_file(&path).unwrap();
        match got {
            Err(TableError::Malformed { line, message }) => {
                assert_eq!(line, first_hole_line, "{name}: {message}");
                assert!(message.contains("longer than"), "{name}: {message}");
            }
            other => panic!("{name}: expected the hole to be a malformed line, got {other:?}"),
        }
    }
    std::fs::remove_dir(&dir).unwrap();
}
