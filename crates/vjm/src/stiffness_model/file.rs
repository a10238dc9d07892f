//! Saving and loading a [`StiffnessModel`]: versioned JSON with a content hash, written
//! atomically.
//!
//! The file is `{"schema": MODEL_SCHEMA, "content_sha256": H, "model": {...}}` where H is the
//! SHA-256 of the compact JSON serialisation of `model` (field order as written by this code,
//! floats in shortest round-trip form). Loading parses `model`, serialises it again the same
//! way and compares: any edited value changes H (reformatting the file does not).
//!
//! The gravity a model was identified under (`gravity`, `inertials_sha256`) was added to
//! schema 1 without changing its number: both fields are left out for a weightless model, so
//! such a file (and its H) is exactly what was written before, and a file without them, of
//! any age, loads as weightless.
//!
//! Where the URDF is: `model.robot.urdf` is the absolute path (resolved when the model was
//! built), and a file written by [`save`](StiffnessModel::save) or
//! [`to_json_at`](StiffnessModel::to_json_at) also records `urdf_relative`, the URDF's path
//! relative to the model file's folder, next to `model` and outside H (it says where the file
//! is, not what the model is: one model saved in two places has one H). A model folder moved
//! together with its URDF still finds it ([`StiffnessModel::recorded_robot`]); the URDF's
//! content hash decides whether it is the robot, wherever it was found.

use std::io::Write;
use std::path::{Component, Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::{ModelError, StiffnessModel};
use crate::chain::SerialChain;
use crate::hashing::sha256_hex;

/// The schema string of the model files this version writes and reads.
pub const MODEL_SCHEMA: &str = "robot-stiffness/vjm-model/1";

#[derive(Serialize)]
struct FileOut<'a> {
    schema: &'static str,
    content_sha256: String,
    #[serde(skip_serializing_if = "Option::is_none")]
    urdf_relative: Option<String>,
    model: &'a StiffnessModel,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FileIn {
    #[allow(dead_code)]
    schema: String,
    content_sha256: String,
    /// Read (so that a mistyped value is refused) but not part of the model: see
    /// [`StiffnessModel::recorded_robot`].
    #[serde(default)]
    #[allow(dead_code)]
    urdf_relative: Option<String>,
    model: StiffnessModel,
}

/// The robot a model file names and where its URDF was found: what
/// [`StiffnessModel::recorded_robot`] returns.
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub struct RecordedRobot {
    /// The file's `model.robot` record.
    pub record: super::RobotRecord,
    /// The file's `urdf_relative`: the URDF's path relative to the model file's folder when it
    /// was written (`/`-separated); `None` in older files and where no relative path exists.
    pub urdf_relative: Option<String>,
    /// Where the URDF was looked for, in order, each once: the recorded absolute path, then
    /// `urdf_relative` joined to the model file's folder, then the recorded path as given
    /// (relative to the current folder; older files record it so), then that path joined to
    /// the model file's folder. Empty for the bundled arm and for URDF text given directly.
    pub tried: Vec<PathBuf>,
    /// The URDF to load: the first of `tried` whose content has the recorded SHA-256, else the
    /// first that is a file (loading the model against it then names what differs); `None`
    /// when none is a file.
    pub urdf: Option<PathBuf>,
}

impl StiffnessModel {
    /// The SHA-256 of the model's canonical (compact) JSON form.
    pub fn content_sha256(&self) -> String {
        // Serialising plain structs of strings, numbers and options cannot fail.
        let bytes = serde_json::to_vec(self).unwrap_or_default();
        sha256_hex(&bytes)
    }

    /// The file text: pretty-printed JSON with the schema and content hash.
    pub fn to_json(&self) -> String {
        self.file_text(None)
    }

    /// The text of the file at `path`: [`to_json`](Self::to_json) with `urdf_relative`, the
    /// URDF's path relative to the folder of `path`, so that the model finds its URDF when
    /// both are moved together. No `urdf_relative` for the bundled arm, URDF text given
    /// directly, or where no relative path exists (another drive). `path` is not opened.
    pub fn to_json_at(&self, path: impl AsRef<Path>) -> String {
        self.file_text(urdf_relative(&self.robot, path.as_ref()))
    }

    fn file_text(&self, urdf_relative: Option<String>) -> String {
        let out = FileOut {
            schema: MODEL_SCHEMA,
            content_sha256: self.content_sha256(),
            urdf_relative,
            model: self,
        };
        let mut s = serde_json::to_string_pretty(&out).unwrap_or_default();
        s.push('\n');
        s
    }

    /// Writes the model to `path` atomically: to a temporary file in the same directory that
    /// is renamed over `path` once complete, so a failure leaves `path` as it was. The text is
    /// [`to_json_at(path)`](Self::to_json_at).
    pub fn save(&self, path: impl AsRef<Path>) -> Result<(), ModelError> {
        let path = path.as_ref();
        let err = |source: std::io::Error| ModelError::Write {
            path: path.display().to_string(),
            source,
        };
        let name = path
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .ok_or_else(|| {
                err(std::io::Error::new(
                    std::io::ErrorKind::InvalidInput,
                    "not a file name",
                ))
            })?;
        let tmp = path.with_file_name(format!(".{name}.{}.tmp", std::process::id()));
        let text = self.to_json_at(path);
        let written = (|| {
            let mut f = std::fs::File::create(&tmp)?;
            f.write_all(text.as_bytes())?;
            f.sync_all()?;
            std::fs::rename(&tmp, path)
        })();
        if let Err(e) = written {
            let _ = std::fs::remove_file(&tmp);
            return Err(err(e));
        }
        Ok(())
    }

    /// Reads a model file and checks that it is intact and describes `chain` (see
    /// [`check_robot`](Self::check_robot)).
    pub fn load(path: impl AsRef<Path>, chain: &SerialChain) -> Result<Self, ModelError> {
        let path = path.as_ref();
        let shown = path.display().to_string();
        // Capped: a huge file (or an endless stream) is refused without being read whole.
        let text =
            crate::bounded::read_capped(path, crate::bounded::MODEL_FILE_MAX_BYTES, "model file")
                .map_err(|e| match e {
                crate::bounded::CappedReadError::Io(source) => ModelError::Read {
                    path: shown.clone(),
                    source,
                },
                crate::bounded::CappedReadError::TooLarge(limit) => ModelError::Limit {
                    path: shown.clone(),
                    limit,
                },
            })?;
        let model = Self::from_json(&text, &shown)?;
        model.check_robot(chain, &shown)?;
        Ok(model)
    }

    /// The robot record of the model file at `path`, read with the same bounds as
    /// [`load`](Self::load) but without checking the rest of the file: which robot to load
    /// before the file can be loaded against it. `None` when the file has no readable record
    /// (then [`load`](Self::load) names what is wrong).
    pub fn robot_of_file(path: impl AsRef<Path>) -> Option<super::RobotRecord> {
        robot_record_of_file(path.as_ref()).map(|(record, _)| record)
    }

    /// The robot record of the model file at `path` (as [`robot_of_file`](Self::robot_of_file))
    /// with where its URDF is: the recorded absolute path, else `urdf_relative` from the model
    /// file's folder (a folder moved with its URDF), else the recorded path as given (older
    /// files), preferring a file with the recorded content (see [`RecordedRobot`]). The
    /// candidates are read with the URDF loader's size cap. `None` when the file has no
    /// readable record.
    pub fn recorded_robot(path: impl AsRef<Path>) -> Option<RecordedRobot> {
        let path = path.as_ref();
        let (record, urdf_relative) = robot_record_of_file(path)?;
        let tried = urdf_candidates(&record, urdf_relative.as_deref(), path);
        let urdf = pick_urdf(&tried, record.urdf_sha256.as_deref());
        Some(RecordedRobot {
            record,
            urdf_relative,
            tried,
            urdf,
        })
    }

    /// Parses the file text (schema and hash checked, no robot check); `name` is used in
    /// errors. Text larger than [`MODEL_FILE_MAX_BYTES`](crate::bounded::MODEL_FILE_MAX_BYTES)
    /// or nesting deeper than [`MODEL_FILE_MAX_DEPTH`](crate::bounded::MODEL_FILE_MAX_DEPTH)
    /// is refused with [`ModelError::Limit`] before it is parsed.
    pub fn from_json(text: &str, name: &str) -> Result<Self, ModelError> {
        let format = |message: String| ModelError::Format {
            path: name.to_string(),
            message,
        };
        crate::bounded::check_model_file_text(text).map_err(|limit| ModelError::Limit {
            path: name.to_string(),
            limit,
        })?;
        let value: serde_json::Value =
            serde_json::from_str(text).map_err(|e| format(format!("not JSON ({e})")))?;
        let schema = value
            .get("schema")
            .ok_or_else(|| format("no `schema` field".into()))?;
        if schema != MODEL_SCHEMA {
            return Err(ModelError::Schema {
                path: name.to_string(),
                found: match schema.as_str() {
                    Some(s) => s.to_string(),
                    None => schema.to_string(),
                },
                expected: MODEL_SCHEMA,
            });
        }
        let file: FileIn = serde_json::from_value(value).map_err(|e| format(e.to_string()))?;
        if file.model.content_sha256() != file.content_sha256 {
            return Err(ModelError::Edited {
                path: name.to_string(),
            });
        }
        file.model.validate().map_err(format)?;
        Ok(file.model)
    }
}

/// The `model.robot` record and the top-level `urdf_relative` of the model file at `path`,
/// read with the loader's bounds; `None` without a readable record.
fn robot_record_of_file(path: &Path) -> Option<(super::RobotRecord, Option<String>)> {
    let text =
        crate::bounded::read_capped(path, crate::bounded::MODEL_FILE_MAX_BYTES, "model file")
            .ok()?;
    crate::bounded::check_model_file_text(&text).ok()?;
    let mut value: serde_json::Value = serde_json::from_str(&text).ok()?;
    let relative = match value.get("urdf_relative") {
        Some(serde_json::Value::String(s)) if !s.is_empty() => Some(s.clone()),
        _ => None,
    };
    let record = serde_json::from_value(value.get_mut("model")?.get_mut("robot")?.take()).ok()?;
    Some((record, relative))
}

/// The URDF file a robot record names (not the bundled arm's name, not empty).
fn recorded_file(record: &super::RobotRecord) -> Option<&str> {
    record
        .urdf
        .as_deref()
        .filter(|u| !u.is_empty() && *u != crate::BUNDLED_URDF_PATH)
}

/// `path` made absolute (against the current folder) with `.` and `..` removed lexically, as
/// Python's `os.path.abspath` does (symbolic links are not resolved); `None` when the current
/// folder is unknown.
pub(super) fn absolute(path: &Path) -> Option<PathBuf> {
    let abs = std::path::absolute(path).ok()?;
    let mut out = PathBuf::new();
    for c in abs.components() {
        match c {
            Component::CurDir => {}
            Component::ParentDir => {
                out.pop();
            }
            other => out.push(other.as_os_str()),
        }
    }
    Some(out)
}

/// The recorded form of a URDF path given when a chain was loaded: absolute (see
/// [`absolute`]) when it names a file, as given otherwise (the bundled arm's name, a path that
/// is not UTF-8, an unknown current folder).
pub(super) fn recorded_urdf_path(given: &str) -> String {
    if given.is_empty() || given == crate::BUNDLED_URDF_PATH {
        return given.to_string();
    }
    absolute(Path::new(given))
        .and_then(|p| p.to_str().map(str::to_string))
        .unwrap_or_else(|| given.to_string())
}

/// `target` relative to the folder `base` (both absolute and normalised), `/`-separated, as
/// Python's `os.path.relpath`; `None` when they do not share a root (another drive) or a part
/// is not UTF-8.
fn relative_path(target: &Path, base: &Path) -> Option<String> {
    let t: Vec<Component<'_>> = target.components().collect();
    let b: Vec<Component<'_>> = base.components().collect();
    if t.first() != b.first() || t.len() < 2 {
        return None;
    }
    let common = t.iter().zip(&b).take_while(|(x, y)| x == y).count();
    let mut parts: Vec<&str> = vec![".."; b.len() - common];
    for c in &t[common..] {
        parts.push(c.as_os_str().to_str()?);
    }
    (!parts.is_empty()).then(|| parts.join("/"))
}

/// The `urdf_relative` of a model file at `model_path` whose robot is `record`.
fn urdf_relative(record: &super::RobotRecord, model_path: &Path) -> Option<String> {
    let urdf = absolute(Path::new(recorded_file(record)?))?;
    let model = absolute(model_path)?;
    relative_path(&urdf, model.parent()?)
}

/// Where to look for the URDF of `record` in a model file at `model_path`, in order, each
/// place once (see [`RecordedRobot::tried`]).
fn urdf_candidates(
    record: &super::RobotRecord,
    urdf_relative: Option<&str>,
    model_path: &Path,
) -> Vec<PathBuf> {
    let Some(given) = recorded_file(record) else {
        return Vec::new();
    };
    let given = Path::new(given);
    let folder = model_path.parent().unwrap_or(Path::new(""));
    let mut all: Vec<PathBuf> = Vec::new();
    if given.is_absolute() {
        all.push(given.to_path_buf());
    }
    if let Some(rel) = urdf_relative {
        all.push(folder.join(rel));
    }
    if !given.is_absolute() {
        all.push(given.to_path_buf());
        all.push(folder.join(given));
    }
    let mut seen: Vec<PathBuf> = Vec::new();
    all.retain(|p| {
        let key = absolute(p).unwrap_or_else(|| p.clone());
        if seen.contains(&key) {
            return false;
        }
        seen.push(key);
        true
    });
    all
}

/// The first of `candidates` whose text has the SHA-256 `sha256`, else the first regular file.
fn pick_urdf(candidates: &[PathBuf], sha256: Option<&str>) -> Option<PathBuf> {
    let files: Vec<&PathBuf> = candidates.iter().filter(|p| p.is_file()).collect();
    let matching = sha256.and_then(|want| {
        files.iter().find(|p| {
            crate::bounded::read_capped(p, crate::bounded::URDF_MAX_BYTES, "URDF")
                .is_ok_and(|text| sha256_hex(text.as_bytes()) == want)
        })
    });
    matching.or(files.first()).map(|p| (*p).clone())
}
