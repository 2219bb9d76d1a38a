//! Rust errors as Python exceptions, with the CLI's messages (the field or setting named).

use cloth::scene::SceneError;
use cloth::ClothError;
use pyo3::exceptions::{PyFileNotFoundError, PyOSError, PyRuntimeError, PyValueError};
use pyo3::PyErr;

/// An error of a run as a Python exception: a bad scene, bad controls or a bad constraint group is
/// a `ValueError`, an unreadable scene file an `OSError` (`FileNotFoundError` when it is missing),
/// anything else (a diverged rollout, a failed solve) a `RuntimeError`. The message is the
/// CLI's: the error and its causes joined by `: `.
pub fn to_py(e: anyhow::Error) -> PyErr {
    let message = clothopt::request::error_chain(&e);
    for cause in e.chain() {
        if let Some(scene) = cause.downcast_ref::<SceneError>() {
            return scene_exception(scene, message);
        }
        if let Some(cloth) = cause.downcast_ref::<ClothError>() {
            match cloth {
                ClothError::Scene(scene) => return scene_exception(scene, message),
                ClothError::Controls(_) | ClothError::InvalidConstraint { .. } => {
                    return PyValueError::new_err(message)
                }
                _ => {}
            }
        }
    }
    PyRuntimeError::new_err(message)
}

/// A bad setting (an argument the caller gave) as a `ValueError`.
pub fn bad_argument(e: anyhow::Error) -> PyErr {
    PyValueError::new_err(clothopt::request::error_chain(&e))
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
