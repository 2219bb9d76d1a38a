//! Child processes: a fresh copy of the running experiment (so that a measurement's peak memory
//! is its own) and the JAX reference benchmark, each checked for success and its output parsed.

use anyhow::{anyhow, ensure, Context, Result};
use serde::de::DeserializeOwned;
use std::path::{Path, PathBuf};
use std::process::Command;

/// A command that runs this program again (an experiment's hidden child mode).
pub fn this_program() -> Result<Command> {
    let exe = std::env::current_exe().context("cannot locate this experiment's executable")?;
    Ok(Command::new(exe))
}

/// `given` (a `--clothopt` flag), or `clothopt` in this program's folder; an error says how to
/// build it.
pub fn clothopt_binary(given: Option<&Path>) -> Result<PathBuf> {
    let path = match given {
        Some(p) => p.to_path_buf(),
        None => {
            let exe = std::env::current_exe().context("cannot locate this program")?;
            exe.with_file_name(format!("clothopt{}", std::env::consts::EXE_SUFFIX))
        }
    };
    ensure!(
        path.is_file(),
        "--clothopt: no clothopt binary at {} (build it with `cargo build --release --bin clothopt`, \
         or pass --clothopt PATH)",
        path.display()
    );
    Ok(path)
}

/// Runs `command` and returns its standard output; `what` names it in the errors (start failure,
/// or a non-zero exit with the child's standard error).
pub fn run(command: &mut Command, what: &str) -> Result<String> {
    run_accepting(command, what, &[0]).map(|(_, stdout)| stdout)
}

/// Runs `command` and returns its exit code and standard output when the code is one of `ok`
/// (a program whose non-zero codes carry a verdict, like `clothopt optimize`'s 3 and 4); any
/// other exit, or a signal, is an error with the child's standard error.
pub fn run_accepting(command: &mut Command, what: &str, ok: &[i32]) -> Result<(i32, String)> {
    let out = command
        .output()
        .with_context(|| format!("cannot start {what}"))?;
    let code = out.status.code().filter(|c| ok.contains(c));
    ensure!(
        code.is_some(),
        "{what} failed: {}",
        String::from_utf8_lossy(&out.stderr).trim()
    );
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    Ok((code.unwrap_or_default(), stdout))
}

/// The last line of `text` that starts with `{`, parsed as JSON (children may print progress
/// before it).
pub fn last_json_line<T: DeserializeOwned>(text: &str, what: &str) -> Result<T> {
    let line = text
        .lines()
        .rev()
        .find(|l| l.trim_start().starts_with('{'))
        .ok_or_else(|| anyhow!("{what} printed no JSON"))?;
    serde_json::from_str(line).with_context(|| format!("unreadable JSON from {what}"))
}

/// Plans the scene file `file` in a `clothopt optimize` child (the binary `clothopt`) with
/// `--time-limit time_limit --search search --out result_path`, so that what it returns is
/// exactly what a user of the command line gets: the result, `optimize`'s exit code (0 achieved,
/// 3 safe but not achieved, 4 no safe plan) and the child's wall-clock seconds. `what` names the
/// run in the errors.
pub fn plan_scene(
    clothopt: &Path,
    file: &Path,
    time_limit: f64,
    search: clothopt::result::SearchMode,
    result_path: &Path,
    what: &str,
) -> Result<(clothopt::result::PlanResult, i32, f64)> {
    let mut command = Command::new(clothopt);
    command
        .arg("optimize")
        .arg(file)
        .arg("--time-limit")
        .arg(time_limit.to_string())
        .args(["--search", search.name(), "--out"])
        .arg(result_path);
    let ((exit_code, _), wall_s) =
        crate::measure::timed(|| run_accepting(&mut command, what, &[0, 3, 4]))?;
    let text = std::fs::read_to_string(result_path)
        .with_context(|| format!("{what}: no result at {}", result_path.display()))?;
    let result = serde_json::from_str(&text)
        .with_context(|| format!("{what}: unreadable result {}", result_path.display()))?;
    Ok((result, exit_code, wall_s))
}

/// Whether `python` can `import jax`.
pub fn jax_available(python: &Path) -> bool {
    Command::new(python)
        .args(["-c", "import jax"])
        .output()
        .is_ok_and(|o| o.status.success())
}

/// Runs the JAX reference `python script SCENE n n_iter` (`SCENE` as the script names it, e.g.
/// `U` for `u_obstacle`) and parses the last JSON line it prints.
pub fn run_jax<T: DeserializeOwned>(
    python: &Path,
    script: &Path,
    scene: &str,
    n: usize,
    n_iter: usize,
) -> Result<T> {
    let what = format!(
        "the JAX benchmark ({} {})",
        python.display(),
        script.display()
    );
    let stdout = run(
        Command::new(python)
            .arg(script)
            .args([scene, &n.to_string(), &n_iter.to_string()]),
        &what,
    )?;
    last_json_line(&stdout, &what)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(serde::Deserialize, Debug, PartialEq)]
    struct Line {
        a: u32,
    }

    #[test]
    fn the_last_json_line_wins() {
        let text = "compiling …\n{\"a\": 1}\nnoise\n  {\"a\": 2}\ndone\n";
        assert_eq!(last_json_line::<Line>(text, "x").unwrap(), Line { a: 2 });
        let e = last_json_line::<Line>("no json here", "the child").unwrap_err();
        assert_eq!(e.to_string(), "the child printed no JSON");
        assert!(last_json_line::<Line>("{\"b\": 1}", "x").is_err());
    }

    #[test]
    fn a_failing_child_reports_its_stderr() {
        let mut c = Command::new("sh");
        c.args(["-c", "echo out; echo 'bad input' >&2; exit 3"]);
        let e = run(&mut c, "the child").unwrap_err();
        assert_eq!(e.to_string(), "the child failed: bad input");
        let mut ok = Command::new("sh");
        ok.args(["-c", "echo 42"]);
        assert_eq!(run(&mut ok, "the child").unwrap().trim(), "42");
    }

    #[test]
    fn accepted_exit_codes_are_results() {
        let mut c = Command::new("sh");
        c.args(["-c", "echo plan; exit 3"]);
        let (code, out) = run_accepting(&mut c, "the child", &[0, 3, 4]).unwrap();
        assert_eq!((code, out.trim()), (3, "plan"));
        let e = run_accepting(&mut c, "the child", &[0, 4]).unwrap_err();
        assert_eq!(e.to_string(), "the child failed: ");
    }
}
