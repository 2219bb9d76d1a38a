//! [`Error`]: what can fail at the library's edge, one variant per kind of failure, each saying
//! what failed. The simulator's and the optimizer's own errors are wrapped, not flattened, so a
//! caller can tell a bad scene or bad controls from a failed run (the Python package maps them to
//! `ValueError`, `OSError` and `RuntimeError` this way).

use std::path::PathBuf;

/// An error of the planning library.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A scene file that cannot be read or parsed, or a scene that fails validation (the
    /// message names the field path).
    #[error(transparent)]
    Scene(#[from] cloth::scene::SceneError),
    /// A name that is neither a built-in scene nor a scene file; the source lists the built-in
    /// scenes.
    #[error("{source}; or give the path of a scene JSON file")]
    UnknownScene {
        /// The built-in lookup's error.
        #[source]
        source: cloth::scene::SceneError,
    },
    /// The simulator rejected its input (controls of the wrong shape, a bad constraint group) or
    /// failed (a rollout that diverged).
    #[error(transparent)]
    Cloth(#[from] cloth::ClothError),
    /// The optimizer rejected its settings or the problem.
    #[error(transparent)]
    Optim(#[from] optim::OptimError),
    /// A setting out of its range: `name` as the caller spells it (`delta`, `--delta`),
    /// `requirement` what it must be and what it was (`must be a finite number > 0, got -1`).
    #[error("{name} {requirement}")]
    InvalidSetting {
        /// The setting's name.
        name: String,
        /// What is required of it, and the value given.
        requirement: String,
    },
    /// The scene grips no particle, so there are no controls to optimize.
    #[error("scene `{scene}` has no control particles: there is nothing to optimize")]
    NothingToOptimize {
        /// The scene's name.
        scene: String,
    },
    /// The cloth starts inside an obstacle, so step 0 cannot be made safe (and
    /// `PlanOptions::allow_unsafe_start` is off); the message says where.
    #[error("{0}")]
    UnsafeStart(String),
    /// L-BFGS was asked to plan a task with inequality rows, which it cannot handle.
    #[error("L-BFGS cannot handle the {rows} inequality constraints of this task; use the SQP")]
    LbfgsWithConstraints {
        /// How many inequality rows the task has.
        rows: usize,
    },
    /// A re-evaluation after the solver returned failed (`what`: of which point).
    #[error("{what}: {source}")]
    Evaluation {
        /// What was being evaluated, e.g. `re-evaluating the best iterate`.
        what: &'static str,
        /// Why it failed.
        #[source]
        source: optim::EvalError,
    },
    /// A rollout returned no states (every rollout has at least the rest state).
    #[error("the rollout has no states")]
    EmptyRollout,
    /// A result without the states asked of it (e.g. read from a file written without them).
    #[error("the result holds no states")]
    NoStates,
    /// An observation file's bad value ([`crate::fit::observations`]): `field` is its path
    /// (`points[3].particle`), after the file's name where it was read from one.
    #[error("observations: {field}: {reason}")]
    Observation {
        /// The field, e.g. `points[3].step`.
        field: String,
        /// Why it is rejected.
        reason: String,
    },
    /// A file that could not be written.
    #[error("cannot write {}: {source}", path.display())]
    Write {
        /// The file.
        path: PathBuf,
        /// The operating system's error.
        #[source]
        source: std::io::Error,
    },
    /// A value that could not be turned into JSON.
    #[error(transparent)]
    Json(#[from] serde_json::Error),
    /// Re-simulating a plan under the check's physics failed ([`crate::physics_check`]).
    #[error("the check under {physics}: {source}")]
    Check {
        /// The check's physics, in words.
        physics: String,
        /// Why it failed (e.g. an effect that physics does not model).
        #[source]
        source: cloth::ClothError,
    },
}

/// A result of the planning library.
pub type Result<T, E = Error> = std::result::Result<T, E>;

/// The error and its causes joined by `: `, leaving out a cause whose text the message before it
/// already contains (a `SceneError::Io` says its OS error itself and also returns it as its
/// source). The CLI prints it after `error: `; the Python package raises it.
pub fn error_chain(e: &(dyn std::error::Error + 'static)) -> String {
    let mut out = e.to_string();
    let mut cause = e.source();
    while let Some(c) = cause {
        let text = c.to_string();
        if !out.contains(&text) {
            out.push_str(": ");
            out.push_str(&text);
        }
        cause = c.source();
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn messages_say_what_failed_once() {
        let e = Error::Write {
            path: "out/r.json".into(),
            source: std::io::Error::new(std::io::ErrorKind::NotFound, "No such file"),
        };
        assert_eq!(error_chain(&e), "cannot write out/r.json: No such file");
        let e = Error::Evaluation {
            what: "re-evaluating the best iterate",
            source: optim::EvalError::new("the rollout diverged"),
        };
        assert_eq!(
            error_chain(&e),
            "re-evaluating the best iterate: the rollout diverged"
        );
        let e = Error::InvalidSetting {
            name: "--delta".into(),
            requirement: "must be a finite number ≥ 0, got -1".into(),
        };
        assert_eq!(e.to_string(), "--delta must be a finite number ≥ 0, got -1");
    }

    #[test]
    fn an_unknown_scene_lists_the_built_in_ones_once() {
        let source = cloth::Scene::builtin("no_such_scene").unwrap_err();
        let listed = source.to_string();
        let e = Error::UnknownScene { source };
        assert_eq!(
            error_chain(&e),
            format!("{listed}; or give the path of a scene JSON file")
        );
    }

    #[test]
    fn the_error_is_send_and_sync() {
        fn check<T: Send + Sync + 'static>() {}
        check::<Error>();
    }
}
