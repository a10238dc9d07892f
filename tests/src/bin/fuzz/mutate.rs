//! Mutations of fuzz inputs: raw bytes, CSV structure (cells, lines, columns, header) and XML
//! attributes. Every mutation is a pure function of the input and the random stream, so a run
//! is reproducible from its seed.

use rand::Rng;
use rand_chacha::ChaCha8Rng;

/// Largest input the harness produces: the issue's bound on file size (1 MB).
pub const MAX_INPUT: usize = 1 << 20;

/// Cell values that break number parsing, finiteness, magnitude and integer checks.
const SPECIAL_NUMBERS: &[&str] = &[
    "nan",
    "NaN",
    "-nan",
    "inf",
    "-inf",
    "infinity",
    "1e308",
    "-1e308",
    "1e309",
    "-1e309",
    "1.7976931348623157e308",
    "5e-324",
    "1e-320",
    "-0",
    "0",
    "-0.0",
    "1",
    "-1",
    "2",
    "3",
    "1000",
    "1e6",
    "-1e6",
    "1e15",
    "1e154",
    "1e155",
    "99999999999999999999999",
    "-9223372036854775808",
    "9223372036854775807",
    "18446744073709551616",
    "",
    " ",
    "+",
    "-",
    ".",
    "e",
    "1e",
    "0x10",
    "1_000",
    "1,5",
    "\"1\"",
    "\"\"",
    "'",
    "１",
    "1.0.0",
    "6.283185307179586",
    "12.566370614359172",
    "3.141592653589793",
    "1e-12",
    "train",
    "test",
    "TRAIN",
    "x",
];

/// Header names a CSV may or may not be expected to have.
const HEADER_NAMES: &[&str] = &[
    "q0",
    "q1",
    "q7",
    "q8",
    "q10",
    "q99",
    "q18446744073709551616",
    "fx",
    "fy",
    "fz",
    "mx",
    "my",
    "mz",
    "dx",
    "dy",
    "dz",
    "rx",
    "ry",
    "rz",
    "pose",
    "set",
    "r11",
    "r12",
    "r13",
    "r21",
    "r22",
    "r23",
    "r31",
    "r32",
    "r33",
    "tx",
    "ty",
    "tz",
    "ref",
    "",
    " ",
    "Q1",
    "DX",
    "\u{feff}q1",
    "x",
];

/// Values for XML attributes: names, joint types, vectors with non-finite or huge parts.
const XML_VALUES: &[&str] = &[
    "",
    " ",
    "nan nan nan",
    "0 0 0",
    "0 0 1",
    "1 0 0",
    "nan 0 0",
    "inf 0 0",
    "1e308 1e308 1e308",
    "0 0",
    "0 0 0 0",
    "a b c",
    "-0 -0 -0",
    "1e-320 0 0",
    "revolute",
    "continuous",
    "prismatic",
    "fixed",
    "floating",
    "planar",
    "spherical",
    "base_link",
    "tool0",
    "panda_link0",
    "panda_link8",
    "link1",
    "link2",
    "nan",
    "inf",
    "-inf",
    "1e308",
    "-1e308",
    "0",
    "-1",
    "1e9",
    "&amp;",
    "<",
    "\"",
    "&#0;",
];

/// Applies 1–4 stacked mutations chosen at random; `xml` enables the XML-aware ones.
pub fn mutate(input: &[u8], xml: bool, rng: &mut ChaCha8Rng) -> Vec<u8> {
    let mut out = input.to_vec();
    let n = rng.random_range(1..=4);
    for _ in 0..n {
        out = mutate_once(&out, xml, rng);
        if out.len() > MAX_INPUT {
            out.truncate(MAX_INPUT);
        }
    }
    out
}

fn mutate_once(input: &[u8], xml: bool, rng: &mut ChaCha8Rng) -> Vec<u8> {
    let kinds = if xml { 13 } else { 10 };
    match rng.random_range(0..kinds) {
        0 => bytes(input, rng),
        1 => truncate(input, rng),
        2..=3 => replace_number(input, rng),
        4 => line_edit(input, rng),
        5 => {
            if xml {
                replace_number(input, rng)
            } else {
                column_edit(input, rng)
            }
        }
        6 => {
            if xml {
                line_edit(input, rng)
            } else {
                header_edit(input, rng)
            }
        }
        7 => repeat_lines(input, rng),
        8 => line_endings(input, rng),
        9 => replace_number(input, rng),
        _ => attribute_edit(input, rng),
    }
}

/// Raw bytes: flip, insert, delete, overwrite with an interesting byte.
fn bytes(input: &[u8], rng: &mut ChaCha8Rng) -> Vec<u8> {
    const INTERESTING: &[u8] = b"\0\xff\xfe\x80,\"'\n\r\t <>&=/;0-.e";
    let mut out = input.to_vec();
    let at = if out.is_empty() {
        0
    } else {
        rng.random_range(0..out.len())
    };
    match rng.random_range(0..4) {
        0 if !out.is_empty() => out[at] ^= 1 << rng.random_range(0..8),
        1 => out.insert(at, INTERESTING[rng.random_range(0..INTERESTING.len())]),
        2 if !out.is_empty() => {
            let len = rng.random_range(1..=16).min(out.len() - at);
            out.drain(at..at + len);
        }
        _ if !out.is_empty() => out[at] = INTERESTING[rng.random_range(0..INTERESTING.len())],
        _ => out.push(rng.random()),
    }
    out
}

fn truncate(input: &[u8], rng: &mut ChaCha8Rng) -> Vec<u8> {
    if input.is_empty() {
        return Vec::new();
    }
    input[..rng.random_range(0..input.len())].to_vec()
}

/// Byte ranges of number-like tokens (digits with sign, dot and exponent).
fn number_spans(input: &[u8]) -> Vec<(usize, usize)> {
    let mut spans = Vec::new();
    let mut i = 0;
    while i < input.len() {
        let c = input[i];
        if c.is_ascii_digit() || (c == b'-' && input.get(i + 1).is_some_and(u8::is_ascii_digit)) {
            let start = i;
            i += 1;
            while i < input.len()
                && matches!(input[i], b'0'..=b'9' | b'.' | b'e' | b'E' | b'-' | b'+')
            {
                i += 1;
            }
            spans.push((start, i));
        } else {
            i += 1;
        }
    }
    spans
}

/// One numeric token → a special value or a random magnitude.
fn replace_number(input: &[u8], rng: &mut ChaCha8Rng) -> Vec<u8> {
    let spans = number_spans(input);
    if spans.is_empty() {
        return bytes(input, rng);
    }
    let (a, b) = spans[rng.random_range(0..spans.len())];
    let value = if rng.random_bool(0.8) {
        SPECIAL_NUMBERS[rng.random_range(0..SPECIAL_NUMBERS.len())].to_string()
    } else {
        let mantissa: f64 = rng.random_range(-10.0..10.0);
        format!("{mantissa}e{}", rng.random_range(-330..330))
    };
    splice(input, a, b, value.as_bytes())
}

fn splice(input: &[u8], a: usize, b: usize, with: &[u8]) -> Vec<u8> {
    let mut out = Vec::with_capacity(input.len() + with.len());
    out.extend_from_slice(&input[..a]);
    out.extend_from_slice(with);
    out.extend_from_slice(&input[b..]);
    out
}

fn lines(input: &[u8]) -> Vec<Vec<u8>> {
    input.split(|&c| c == b'\n').map(<[u8]>::to_vec).collect()
}

fn join(lines: &[Vec<u8>]) -> Vec<u8> {
    lines.join(&b'\n')
}

/// Duplicate, remove, swap or empty a line.
fn line_edit(input: &[u8], rng: &mut ChaCha8Rng) -> Vec<u8> {
    let mut ls = lines(input);
    if ls.is_empty() {
        return bytes(input, rng);
    }
    let i = rng.random_range(0..ls.len());
    let j = rng.random_range(0..ls.len());
    match rng.random_range(0..4) {
        0 => {
            let l = ls[i].clone();
            ls.insert(j, l);
        }
        1 => {
            ls.remove(i);
        }
        2 => ls.swap(i, j),
        _ => ls[i].clear(),
    }
    join(&ls)
}

/// Repeats a line many times (large files, many rows, repeated elements).
fn repeat_lines(input: &[u8], rng: &mut ChaCha8Rng) -> Vec<u8> {
    let mut ls = lines(input);
    if ls.len() < 2 {
        return bytes(input, rng);
    }
    let i = rng.random_range(1..ls.len());
    let times = [2usize, 10, 100, 1000, 20_000][rng.random_range(0..5)];
    let line = ls[i].clone();
    let budget = MAX_INPUT / (line.len() + 1).max(1);
    for _ in 0..times.min(budget) {
        ls.insert(i, line.clone());
    }
    join(&ls)
}

/// CRLF, CR-only, blank lines, trailing separators, a BOM or no final newline.
fn line_endings(input: &[u8], rng: &mut ChaCha8Rng) -> Vec<u8> {
    match rng.random_range(0..5) {
        0 => join(&lines(input))
            .split(|&c| c == b'\n')
            .collect::<Vec<_>>()
            .join(&b"\r\n"[..]),
        1 => input
            .iter()
            .map(|&c| if c == b'\n' { b'\r' } else { c })
            .collect(),
        2 => [b"\xef\xbb\xbf".as_slice(), input].concat(),
        3 => {
            let mut ls = lines(input);
            for l in &mut ls {
                l.push(b',');
            }
            join(&ls)
        }
        _ => {
            let mut ls = lines(input);
            let at = rng.random_range(0..=ls.len());
            ls.insert(at, Vec::new());
            join(&ls)
        }
    }
}

fn cells(line: &[u8]) -> Vec<Vec<u8>> {
    line.split(|&c| c == b',').map(<[u8]>::to_vec).collect()
}

/// Removes, duplicates or swaps a column in every line.
fn column_edit(input: &[u8], rng: &mut ChaCha8Rng) -> Vec<u8> {
    let ls = lines(input);
    let width = ls.first().map_or(0, |l| cells(l).len());
    if width == 0 {
        return bytes(input, rng);
    }
    let c = rng.random_range(0..width);
    let d = rng.random_range(0..width);
    let kind = rng.random_range(0..3);
    let edited: Vec<Vec<u8>> = ls
        .iter()
        .map(|l| {
            let mut cs = cells(l);
            if c < cs.len() && d < cs.len() {
                match kind {
                    0 => {
                        cs.remove(c);
                    }
                    1 => {
                        let v = cs[c].clone();
                        cs.insert(d, v);
                    }
                    _ => cs.swap(c, d),
                }
            }
            cs.join(&b',')
        })
        .collect();
    join(&edited)
}

/// Renames, duplicates or removes one header name.
fn header_edit(input: &[u8], rng: &mut ChaCha8Rng) -> Vec<u8> {
    let mut ls = lines(input);
    if ls.is_empty() {
        return bytes(input, rng);
    }
    let mut cs = cells(&ls[0]);
    let i = rng.random_range(0..cs.len());
    let name = HEADER_NAMES[rng.random_range(0..HEADER_NAMES.len())]
        .as_bytes()
        .to_vec();
    match rng.random_range(0..4) {
        0 => cs[i] = name,
        1 => cs.push(name),
        2 => cs[i] = cs[i].to_ascii_uppercase(),
        _ => cs[i].insert(0, b' '),
    }
    ls[0] = cs.join(&b',');
    join(&ls)
}

/// Byte ranges of XML attribute values (between the quotes of `name="value"`).
fn attribute_spans(input: &[u8]) -> Vec<(usize, usize)> {
    let mut spans = Vec::new();
    let mut i = 0;
    while i + 1 < input.len() {
        if input[i] == b'=' && input[i + 1] == b'"' {
            let start = i + 2;
            if let Some(len) = input[start..].iter().position(|&c| c == b'"') {
                spans.push((start, start + len));
                i = start + len + 1;
                continue;
            }
        }
        i += 1;
    }
    spans
}

/// Replaces one attribute value by a special one or by another attribute's value (which
/// renames links and joints, re-parents joints, makes cycles and changes joint types).
fn attribute_edit(input: &[u8], rng: &mut ChaCha8Rng) -> Vec<u8> {
    let spans = attribute_spans(input);
    if spans.is_empty() {
        return bytes(input, rng);
    }
    let (a, b) = spans[rng.random_range(0..spans.len())];
    let value: Vec<u8> = if rng.random_bool(0.5) {
        XML_VALUES[rng.random_range(0..XML_VALUES.len())]
            .as_bytes()
            .to_vec()
    } else {
        let (c, d) = spans[rng.random_range(0..spans.len())];
        input[c..d].to_vec()
    };
    splice(input, a, b, &value)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    #[test]
    fn mutations_are_reproducible_and_bounded() {
        let seed = b"q1,fx\n1.5,2\n-3,4e-2\n";
        let run = |s| {
            let mut rng = ChaCha8Rng::seed_from_u64(s);
            (0..200)
                .map(|_| mutate(seed, false, &mut rng))
                .collect::<Vec<_>>()
        };
        assert_eq!(run(7), run(7));
        assert_ne!(run(7), run(8));
        assert!(run(9).iter().all(|m| m.len() <= MAX_INPUT));
    }

    #[test]
    fn number_and_attribute_spans_find_the_tokens() {
        assert_eq!(number_spans(b"a,-1.5e3,x7"), vec![(2, 8), (10, 11)]);
        assert_eq!(
            attribute_spans(br#"<a b="1 2" c="x"/>"#),
            vec![(6, 9), (14, 15)]
        );
    }
}
