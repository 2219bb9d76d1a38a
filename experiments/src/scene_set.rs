//! The scene files of a benchmark set (`examples/scenes/routes/`, `examples/scenes/table/`).

use anyhow::{bail, Context, Result};
use cloth::Scene;
use serde_json::Value;
use std::path::{Path, PathBuf};

/// A scene file of a set: its path, name and text.
pub struct SceneFile {
    /// Where it is.
    pub path: PathBuf,
    /// The scene's `name`.
    pub name: String,
    /// The file's text.
    pub text: String,
}

/// The scenes of the set `dir` (only `names` when given, [`load_set`]), each with its file's
/// text.
pub fn scene_files(dir: &Path, names: &[String]) -> Result<Vec<SceneFile>> {
    let mut files = Vec::new();
    for (path, scene) in load_set(dir, names, "--dir")? {
        let text = std::fs::read_to_string(&path)
            .with_context(|| format!("cannot read {}", path.display()))?;
        files.push(SceneFile {
            path,
            name: scene.name,
            text,
        });
    }
    Ok(files)
}

/// Makes the files a scene names (`cloth.mesh`, `cloth.initial_state.obj`, `task.target_mesh`,
/// `obstacles[i].file`; see docs/scene-format.md) absolute, so that a variant of the scene
/// written elsewhere reads them from anywhere.
pub fn absolute_files(scene: &mut Value, base: &Path) -> Result<()> {
    let base = base
        .canonicalize()
        .with_context(|| format!("cannot resolve {}", base.display()))?;
    for pointer in [
        "/cloth/mesh",
        "/cloth/initial_state/obj",
        "/task/target_mesh",
    ] {
        if let Some(v) = scene.pointer_mut(pointer) {
            absolutize(v, &base);
        }
    }
    if let Some(obstacles) = scene.get_mut("obstacles").and_then(Value::as_array_mut) {
        for o in obstacles {
            if let Some(v) = o.get_mut("file") {
                absolutize(v, &base);
            }
        }
    }
    Ok(())
}

/// A relative path string `v` joined to `base`.
fn absolutize(v: &mut Value, base: &Path) {
    if let Some(s) = v.as_str() {
        if Path::new(s).is_relative() {
            *v = Value::String(base.join(s).to_string_lossy().into_owned());
        }
    }
}

/// Every `*.json` scene in `dir`, sorted by file name, loaded; only those named in `names` when
/// it is not empty. A file that does not load is an error naming it; so is a name that matches no
/// scene (listing the set's names). `flag` names the directory's flag in the errors.
pub fn load_set(dir: &Path, names: &[String], flag: &str) -> Result<Vec<(PathBuf, Scene)>> {
    let entries =
        std::fs::read_dir(dir).with_context(|| format!("{flag}: cannot read {}", dir.display()))?;
    let mut paths: Vec<PathBuf> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "json"))
        .collect();
    paths.sort();
    let mut set = Vec::new();
    for path in paths {
        let scene = Scene::load(&path).with_context(|| format!("{}", path.display()))?;
        set.push((path, scene));
    }
    if set.is_empty() {
        bail!("{flag}: no scene files in {}", dir.display());
    }
    for name in names {
        if !set.iter().any(|(_, s)| &s.name == name) {
            let known: Vec<&str> = set.iter().map(|(_, s)| s.name.as_str()).collect();
            bail!(
                "scene `{name}` is not in {} (its scenes: {})",
                dir.display(),
                known.join(", ")
            );
        }
    }
    set.retain(|(_, s)| names.is_empty() || names.contains(&s.name));
    Ok(set)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_set_is_its_scenes_by_file_name_and_names_are_checked() {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/scenes/table");
        let all = load_set(&dir, &[], "--dir").unwrap();
        let names: Vec<&str> = all.iter().map(|(_, s)| s.name.as_str()).collect();
        assert_eq!(
            names,
            [
                "bar_to_table",
                "drape_box",
                "fold_towel",
                "lay_flat",
                "place_beside"
            ]
        );
        let one = load_set(&dir, &["lay_flat".into()], "--dir").unwrap();
        assert_eq!(one.len(), 1);
        let e = load_set(&dir, &["nosuch".into()], "--dir").unwrap_err();
        assert!(e.to_string().starts_with("scene `nosuch` is not in"), "{e}");
        let e = load_set(&dir.join("missing"), &[], "--dir").unwrap_err();
        assert!(e.to_string().starts_with("--dir: cannot read"), "{e}");
    }

    #[test]
    fn relative_files_become_absolute() {
        let mut v: Value = serde_json::from_str(
            r#"{"cloth": {"mesh": "towel.obj", "initial_state": {"obj": "c.obj"}},
                "task": {"target_mesh": "/abs/t.obj"},
                "obstacles": [{"type": "mesh", "file": "vase.obj"}, {"type": "plane"}]}"#,
        )
        .unwrap();
        let dir = std::env::temp_dir();
        absolute_files(&mut v, &dir).unwrap();
        let base = dir.canonicalize().unwrap();
        assert_eq!(
            v["cloth"]["mesh"],
            base.join("towel.obj").to_string_lossy().as_ref()
        );
        assert_eq!(
            v["cloth"]["initial_state"]["obj"],
            base.join("c.obj").to_string_lossy().as_ref()
        );
        assert_eq!(v["task"]["target_mesh"], "/abs/t.obj");
        assert_eq!(
            v["obstacles"][0]["file"],
            base.join("vase.obj").to_string_lossy().as_ref()
        );
        assert!(v["obstacles"][1].get("file").is_none());
    }
}
