//! Seeds on disk (`tests/fuzz/corpus/<target>/*`, kept small in the repository) plus the
//! bundled Panda URDF, and the inputs a run adds when they reach an outcome not seen before.

use std::collections::{BTreeMap, BTreeSet};
use std::io;
use std::path::Path;

use crate::mutate::MAX_INPUT;
use crate::targets::Target;

/// Most inputs kept per target (seeds plus discoveries).
const MAX_ENTRIES: usize = 512;

/// The inputs of every target, and the outcome classes seen so far.
#[derive(Debug, Default)]
pub struct Corpus {
    entries: BTreeMap<Target, Vec<Vec<u8>>>,
    seen: BTreeSet<(Target, String)>,
    /// Number of seeds read (files plus built-in).
    pub seeds: usize,
    /// Bytes of the seeds.
    pub seed_bytes: usize,
    /// Inputs added during the run.
    pub discovered: usize,
}

impl Corpus {
    /// Reads `dir/<target>/*` in name order and adds the built-in seeds.
    pub fn load(dir: &Path) -> io::Result<Self> {
        let mut corpus = Corpus::default();
        for target in Target::ALL {
            let sub = dir.join(target.name());
            let mut files: Vec<_> = match std::fs::read_dir(&sub) {
                Ok(rd) => rd.collect::<Result<Vec<_>, _>>()?,
                Err(e) if e.kind() == io::ErrorKind::NotFound => Vec::new(),
                Err(e) => return Err(e),
            };
            files.sort_by_key(|f| f.file_name());
            for f in files {
                if f.file_type()?.is_file() {
                    corpus.add_seed(target, std::fs::read(f.path())?);
                }
            }
        }
        let panda = format!(
            "<!-- base={} tip={} -->\n{}",
            vjm::BUNDLED_BASE,
            vjm::BUNDLED_FLANGE,
            vjm::BUNDLED_URDF
        );
        corpus.add_seed(Target::Urdf, panda.into_bytes());
        for target in Target::ALL {
            if corpus.of(target).is_empty() {
                corpus.add_seed(target, Vec::new());
            }
        }
        Ok(corpus)
    }

    fn add_seed(&mut self, target: Target, bytes: Vec<u8>) {
        self.seeds += 1;
        self.seed_bytes += bytes.len();
        self.entries.entry(target).or_default().push(bytes);
    }

    /// The inputs of a target.
    pub fn of(&self, target: Target) -> &[Vec<u8>] {
        self.entries.get(&target).map_or(&[], Vec::as_slice)
    }

    /// Every (target, input) pair, seeds first.
    pub fn all(&self) -> Vec<(Target, Vec<u8>)> {
        Target::ALL
            .into_iter()
            .flat_map(|t| self.of(t).iter().map(move |b| (t, b.clone())))
            .collect()
    }

    /// Notes an outcome class; keeps the input when the class is new (a crude stand-in for
    /// coverage feedback: new error messages mean new code paths in the validation).
    pub fn observe(&mut self, target: Target, class: String, input: &[u8]) -> bool {
        if !self.seen.insert((target, class)) {
            return false;
        }
        let list = self.entries.entry(target).or_default();
        if list.len() < MAX_ENTRIES && input.len() <= MAX_INPUT / 4 {
            list.push(input.to_vec());
            self.discovered += 1;
        }
        true
    }

    /// Total inputs held now.
    pub fn len(&self) -> usize {
        self.entries.values().map(Vec::len).sum()
    }
}

/// The class of an outcome: its kind and its message with numbers and quoted text blanked, so
/// "line 7, column 'q3'" and "line 9, column 'q5'" are one class.
pub fn outcome_class(kind: &str, text: &str) -> String {
    let mut out = String::from(kind);
    out.push(':');
    let mut quoted: Option<char> = None;
    let mut last_hash = false;
    for c in text.chars() {
        if let Some(q) = quoted {
            if c == q {
                quoted = None;
            }
            continue;
        }
        if c == '\'' || c == '"' || c == '`' {
            quoted = Some(c);
            out.push('_');
            continue;
        }
        if c.is_ascii_digit() || c == '.' || (c == 'e' && last_hash) {
            if !last_hash {
                out.push('#');
            }
            last_hash = true;
            continue;
        }
        last_hash = false;
        out.push(c);
        if out.len() > 120 {
            break;
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::outcome_class;

    #[test]
    fn classes_blank_numbers_and_quotes() {
        assert_eq!(
            outcome_class("err", "line 7, column 'q3': 1.5e3 bad"),
            outcome_class("err", "line 12, column 'dx': 7 bad")
        );
        assert_ne!(outcome_class("err", "a"), outcome_class("ok", "a"));
    }
}
