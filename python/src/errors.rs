//! Rust errors as Python exceptions, with the CLI's messages (the field or setting named).

use cloth::scene::SceneError;
use cloth::ClothError;
use clothopt::{error_chain, Error};
use pyo3::exceptions::{PyFileNotFoundError, PyOSError, PyRuntimeError, PyValueError};
use pyo3::PyErr;
use std::path::Path;

/// An error of a run as a Python exception: a bad scene, bad controls, a bad constraint group, a
/// bad observation or a bad setting is a `ValueError`, an unreadable scene file an `OSError`
/// (`FileNotFoundError` when it is missing), anything else (a diverged rollout, a failed solve) a
/// `RuntimeError`. The message is the CLI's: the error and its causes joined by `: `.
pub fn to_py(e: Error) -> PyErr {
    let message = error_chain(&e);
    match &e {
        Error::Scene(scene) | Error::Cloth(ClothError::Scene(scene)) => {
            scene_exception(scene, message)
        }
        Error::UnknownScene { .. }
        | Error::InvalidSetting { .. }
        | Error::Observation { .. }
        | Error::Cloth(ClothError::Controls(_) | ClothError::InvalidConstraint { .. }) => {
            PyValueError::new_err(message)
        }
        _ => PyRuntimeError::new_err(message),
    }
}

/// An error reading the observation file `path`: one that cannot be read is an `OSError`
/// (`FileNotFoundError` when it is missing), with the CLI's message; others as [`to_py`].
pub fn observation_file_error(path: &Path, e: Error) -> PyErr {
    match &e {
        // The library names an unreadable file's field `(file)`; a bad one's field starts with
        // the path.
        Error::Observation { field, .. } if field == "(file)" => {
            let message = error_chain(&e);
            match std::fs::metadata(path) {
                Err(io) if io.kind() == std::io::ErrorKind::NotFound => {
                    PyFileNotFoundError::new_err(message)
                }
                _ => PyOSError::new_err(message),
            }
        }
        _ => to_py(e),
    }
}

/// A bad setting (an argument the caller gave) as a `ValueError`.
pub fn bad_argument(e: Error) -> PyErr {
    PyValueError::new_err(error_chain(&e))
}

fn scene_exception(scene: &SceneError, message: String) -> PyErr {
    match scene {
        SceneError::Io { source, .. } if source.kind() == std::io::ErrorKind::NotFound => {
            PyFileNotFoundError::new_err(message)
        }
        SceneError::Io { .. } => PyOSError::new_err(message),
        _ => PyValueError::new_err(message),
    }
}
