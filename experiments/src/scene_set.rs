//! The scene files of a benchmark set (`examples/scenes/routes/`, `examples/scenes/table/`).

use anyhow::{bail, Context, Result};
use cloth::Scene;
use std::path::{Path, PathBuf};

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
}
