//! Scenes: the file a user writes (TOML or JSON), its validation, and the
//! [`Plan`] of stages a validated scene needs.
//!
//! Entry points: [`Scene::from_path`] and [`Scene::from_text`]. Every
//! mistake becomes a [`SceneError`] whose entries name the field path and
//! the reason, e.g. `bodies[1].material.youngs_modulus: must be > 0, got -3`.

mod memory;
mod plan;
pub mod schema;
pub(crate) mod validate;

pub use crate::fracture::damage::section::ResolvedDamage;
pub use crate::fracture::phase_field::section::phase_field_gamma;
pub use memory::{human_bytes, MemoryBudget, MemoryEstimate};
pub use plan::{Plan, Stage};
pub use schema::*;
pub(crate) use validate::Checker;
pub use validate::{
    MaterialFracture, ResolvedMaterial, Scene, TimeStepEstimate, DEFAULT_MAX_STEPS,
    MAX_CONTACT_GROUPS,
};

use std::fmt;
use std::path::Path;

/// One problem in a scene: where and why.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct FieldError {
    /// Dotted path into the scene, e.g. `bodies[1].material.density`; empty
    /// for the file as a whole.
    pub path: String,
    pub reason: String,
}

impl fmt::Display for FieldError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.path.is_empty() {
            write!(f, "{}", self.reason)
        } else {
            write!(f, "{}: {}", self.path, self.reason)
        }
    }
}

/// A scene that cannot be run, with every problem found.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub struct SceneError {
    pub errors: Vec<FieldError>,
}

impl SceneError {
    pub fn single(path: impl Into<String>, reason: impl Into<String>) -> Self {
        SceneError {
            errors: vec![FieldError {
                path: path.into(),
                reason: reason.into(),
            }],
        }
    }
}

impl fmt::Display for SceneError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (i, e) in self.errors.iter().enumerate() {
            if i > 0 {
                writeln!(f)?;
            }
            write!(f, "{e}")?;
        }
        Ok(())
    }
}

/// The text format of a scene.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Format {
    Toml,
    Json,
}

impl Format {
    /// Guess from the content: JSON if the first non-blank character is `{`.
    pub fn sniff(text: &str) -> Format {
        if text.trim_start().starts_with('{') {
            Format::Json
        } else {
            Format::Toml
        }
    }
}

impl Scene {
    /// Reads, parses and validates a scene file (`.json` is JSON, anything
    /// else is sniffed).
    pub fn from_path(path: &Path) -> Result<Scene, SceneError> {
        let bytes = std::fs::read(path).map_err(|e| {
            SceneError::single(
                "",
                format!("cannot read scene file {}: {e}", path.display()),
            )
        })?;
        let format = match path.extension().and_then(|e| e.to_str()) {
            Some("json") => Some(Format::Json),
            Some("toml") => Some(Format::Toml),
            _ => None,
        };
        Scene::from_bytes(&bytes, format)
    }

    /// Parses and validates scene bytes; `format` None means sniff.
    pub fn from_bytes(bytes: &[u8], format: Option<Format>) -> Result<Scene, SceneError> {
        let text = std::str::from_utf8(bytes).map_err(|e| {
            SceneError::single(
                "",
                format!(
                    "the scene is not UTF-8 text (invalid byte at offset {})",
                    e.valid_up_to()
                ),
            )
        })?;
        Scene::from_text(text, format)
    }

    /// Parses and validates scene text; `format` None means sniff.
    pub fn from_text(text: &str, format: Option<Format>) -> Result<Scene, SceneError> {
        let file = parse(text, format.unwrap_or_else(|| Format::sniff(text)))?;
        Scene::validate(file)
    }

    /// [`Scene::from_text`] with the memory estimate checked against
    /// `budget` ([`Scene::validate_within`]).
    pub fn from_text_within(
        text: &str,
        format: Option<Format>,
        budget: &MemoryBudget,
    ) -> Result<Scene, SceneError> {
        let file = parse(text, format.unwrap_or_else(|| Format::sniff(text)))?;
        Scene::validate_within(file, budget)
    }
}

/// Parses scene text into the raw [`SceneFile`], naming the field path of
/// any type error, unknown key or missing key.
pub fn parse(text: &str, format: Format) -> Result<SceneFile, SceneError> {
    if text.trim().is_empty() {
        return Err(SceneError::single(
            "",
            "the scene is empty (it needs at least [grid], [time] and [[bodies]])",
        ));
    }
    if text.contains('\0') {
        return Err(SceneError::single(
            "",
            "the scene contains NUL bytes: it is not a text file",
        ));
    }
    match format {
        Format::Toml => {
            let de = toml::Deserializer::parse(text)
                .map_err(|e| SceneError::single("", toml_message(&e, text)))?;
            serde_path_to_error::deserialize(de).map_err(|e| {
                let path = clean_path(&e.path().to_string());
                SceneError::single(path, toml_message(e.inner(), text))
            })
        }
        Format::Json => {
            let mut de = serde_json::Deserializer::from_str(text);
            let file: SceneFile = serde_path_to_error::deserialize(&mut de).map_err(|e| {
                let path = clean_path(&e.path().to_string());
                SceneError::single(path, e.inner().to_string())
            })?;
            de.end().map_err(|e| {
                SceneError::single("", format!("trailing characters after the scene: {e}"))
            })?;
            Ok(file)
        }
    }
}

fn clean_path(p: &str) -> String {
    if p == "." {
        String::new()
    } else {
        p.to_string()
    }
}

/// toml's bare message plus the line and column it points at.
fn toml_message(e: &toml::de::Error, text: &str) -> String {
    let msg = e.message().trim().to_string();
    match e.span() {
        Some(span) => {
            let before = text.get(..span.start).unwrap_or(text);
            let line = before.matches('\n').count() + 1;
            let column = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
            format!("{msg} (line {line}, column {column})")
        }
        None => msg,
    }
}
