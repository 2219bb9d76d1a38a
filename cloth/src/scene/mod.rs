//! The scene file format (JSON via serde), its validation, and the built-in scenes.
//!
//! A [`Scene`] describes one cloth-manipulation task: the cloth grid and its placement, the material,
//! the time stepping, the control (gripped) particles, obstacles, and the task (targets, cost weights,
//! horizon and the initial control guess). Every struct rejects unknown fields, and
//! [`Scene::validate`] rejects every bad value with a [`SceneError::Invalid`] naming the field path, e.g.
//! `task.targets[3].particle: row 12 out of range (cloth.rows = 10)`.
//!
//! ```
//! use cloth::scene::Scene;
//! let scene = Scene::builtin("u_obstacle")?;
//! assert_eq!(scene.mesh().n_particles(), 100);
//! assert_eq!(scene.control_indices(), vec![0, 9]);
//! # Ok::<(), cloth::scene::SceneError>(())
//! ```
//!
//! The built-in scenes live in `examples/scenes/{u_obstacle,swing,drop}.json` and are embedded in the
//! library; [`Scene::builtin_names`] lists them.

mod builtin;
mod files;
mod format;
mod initial_state;
mod json;
mod limits;
mod obstacles;
mod physics_choice;
mod validate;

#[cfg(test)]
mod tests;

use std::path::{Path, PathBuf};

pub use format::*;
pub use initial_state::{InitialState, Recipe, DEFAULT_SETTLE_STEPS};
pub use json::to_json_pretty_compact;
pub use obstacles::*;
pub use physics_choice::{PhysicsChoice, PhysicsReason};

use builtin::{builtin_list, BUILTIN_NAMES, BUILTIN_SOURCES};
use json::{one_line, parse_error};

/// Largest accepted number of particles (`cloth.rows × cloth.cols`); larger grids are rejected by
/// validation instead of exhausting memory.
pub const MAX_PARTICLES: usize = 1 << 24;

/// Largest accepted `task.horizon` (number of time steps).
pub const MAX_HORIZON: usize = 1 << 20;

/// Largest accepted magnitude of a length-like value: every coordinate and vector component
/// (positions, `right`, `down`, gravity, targets, sphere centres, plane points and normals, initial
/// controls), sphere radii and `task.delta`. Beyond it squared distances and energies approach the
/// range of `f64`, and a rollout overflows instead of failing validation.
pub const MAX_COORDINATE: f64 = 1e9;

/// Errors from reading, parsing or validating a scene.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// The text is not a scene: malformed JSON, unknown or missing field, wrong type. `message` is
    /// serde_json's (it names unknown/missing fields and gives line and column), followed by the offending
    /// source line.
    #[error("invalid scene JSON: {message}")]
    Parse {
        /// Human-readable parser message, including line and column.
        message: String,
    },
    /// A well-formed scene with a bad value; `field` is its path, e.g. `cloth.top_left[1]`.
    #[error("{field}: {reason}")]
    Invalid {
        /// Path of the offending field, e.g. `task.targets[3].particle`.
        field: String,
        /// Why the value is rejected.
        reason: String,
    },
    /// The scene file could not be read.
    #[error("cannot read scene file `{}`: {source}", path.display())]
    Io {
        /// The path that was read.
        path: PathBuf,
        /// The underlying I/O error.
        source: std::io::Error,
    },
    /// [`Scene::builtin`] was asked for a name that is not built in.
    #[error(
        "unknown built-in scene `{}` (available: {})",
        one_line(name),
        builtin_list()
    )]
    UnknownBuiltin {
        /// The requested name.
        name: String,
    },
}

impl Scene {
    /// Parses a scene from JSON text and validates it.
    ///
    /// Files the scene names (mesh obstacles) are read relative to the working directory.
    pub fn from_json_str(text: &str) -> Result<Scene, SceneError> {
        Scene::from_json_str_in(text, Path::new(""))
    }

    /// Parses a scene from JSON text, reads the files it names relative to `base`
    /// ([`Scene::load_files`]) and validates it.
    pub fn from_json_str_in(text: &str, base: &Path) -> Result<Scene, SceneError> {
        let mut scene: Scene = serde_json::from_str(text).map_err(|e| parse_error(text, &e))?;
        scene.load_files(base)?;
        scene.validate()?;
        Ok(scene)
    }

    /// Reads, parses and validates a scene file; the files it names are relative to its folder.
    pub fn load(path: impl AsRef<Path>) -> Result<Scene, SceneError> {
        let path = path.as_ref();
        let text = std::fs::read_to_string(path).map_err(|source| SceneError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        Scene::from_json_str_in(&text, path.parent().unwrap_or(Path::new("")))
    }

    /// One of the built-in scenes (see [`Scene::builtin_names`]), embedded from `examples/scenes/`.
    pub fn builtin(name: &str) -> Result<Scene, SceneError> {
        BUILTIN_NAMES
            .iter()
            .position(|(n, _)| *n == name)
            .map(|i| {
                let text = BUILTIN_SOURCES[i];
                let mut scene: Scene =
                    serde_json::from_str(text).map_err(|e| parse_error(text, &e))?;
                scene.load_files_from(&files::Source::Builtin)?;
                scene.validate()?;
                Ok(scene)
            })
            .unwrap_or_else(|| {
                Err(SceneError::UnknownBuiltin {
                    name: name.to_string(),
                })
            })
    }

    /// Names and one-line descriptions of the built-in scenes: `u_obstacle`, `swing`, `drop`,
    /// `fold`.
    pub fn builtin_names() -> &'static [(&'static str, &'static str)] {
        BUILTIN_NAMES
    }

    /// The scene as pretty-printed JSON; [`Scene::from_json_str`] reads it back to an equal scene
    /// (bit-identical floats).
    pub fn to_json_pretty(&self) -> String {
        // Serializing these plain data types cannot fail whatever their values (no maps, no fallible
        // custom serializers; non-finite floats are written as `null`), so this never panics.
        to_json_pretty_compact(self).expect("serializing a Scene is infallible")
    }
}

/// A [`SceneError::Invalid`] for `field`.
fn invalid(field: impl Into<String>, reason: impl Into<String>) -> SceneError {
    SceneError::Invalid {
        field: field.into(),
        reason: reason.into(),
    }
}
