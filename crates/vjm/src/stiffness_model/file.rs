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

use std::io::Write;
use std::path::Path;

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
    model: &'a StiffnessModel,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FileIn {
    #[allow(dead_code)]
    schema: String,
    content_sha256: String,
    model: StiffnessModel,
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
        let out = FileOut {
            schema: MODEL_SCHEMA,
            content_sha256: self.content_sha256(),
            model: self,
        };
        let mut s = serde_json::to_string_pretty(&out).unwrap_or_default();
        s.push('\n');
        s
    }

    /// Writes the model to `path` atomically: to a temporary file in the same directory that
    /// is renamed over `path` once complete, so a failure leaves `path` as it was.
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
        let text = self.to_json();
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
        let path = path.as_ref();
        let text =
            crate::bounded::read_capped(path, crate::bounded::MODEL_FILE_MAX_BYTES, "model file")
                .ok()?;
        crate::bounded::check_model_file_text(&text).ok()?;
        let mut value: serde_json::Value = serde_json::from_str(&text).ok()?;
        serde_json::from_value(value.get_mut("model")?.get_mut("robot")?.take()).ok()
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
