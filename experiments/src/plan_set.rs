//! Planning a scene set under several variants (contact models, physics): the flags such an
//! experiment shares, its folders (a scratch folder for variants and results, `--results-dir` for
//! the results kept), and one row per scene and variant, each a planned result, a variant the
//! simulator refuses, or a failed child.

use crate::child;
use crate::report::{last_line, one_line, write_json};
use crate::scene_set::{absolute_files, scene_files, SceneFile};
use anyhow::{Context, Result};
use clothopt::result::{PlanResult, SearchMode};
use serde::Serialize;
use serde_json::Value;
use std::path::{Path, PathBuf};

/// The flags of a set experiment beside its scenes, folder and variants.
#[derive(clap::Args)]
pub struct PlanFlags {
    /// Route search of each plan (`optimize --search`).
    #[arg(long, value_enum, default_value_t = SearchMode::Auto)]
    pub search: SearchMode,
    /// The `clothopt` binary (default: the one beside this program).
    #[arg(long)]
    pub clothopt: Option<PathBuf>,
    /// Keep each plan's result JSON here, as `<scene>.<variant>.json` (a controls file for
    /// `clothopt simulate --controls` and `roughness --controls`).
    #[arg(long)]
    pub results_dir: Option<PathBuf>,
    /// Write the settings and every row as JSON here (atomically).
    #[arg(long)]
    pub out: Option<PathBuf>,
}

/// What happened to one scene under one variant.
#[derive(Serialize)]
#[serde(tag = "outcome", rename_all = "snake_case")]
pub enum Outcome<P> {
    /// The plan ran; what the experiment reads from it.
    Planned(Box<P>),
    /// The simulator refused the variant for this scene (it does not load, validate or compile).
    Unsupported {
        /// Its error, on one line.
        message: String,
    },
    /// The planning child failed.
    Error {
        /// The last line of its error.
        message: String,
    },
}

/// One row: the scene, the variant and what happened.
#[derive(Serialize)]
pub struct Row<V, P> {
    /// The scene's name.
    pub scene: String,
    /// The variant it was planned under.
    pub variant: V,
    /// What happened.
    #[serde(flatten)]
    pub outcome: Outcome<P>,
}

/// A set experiment's plans: the `clothopt` binary, the scenes and the folders.
pub struct PlanSet {
    /// The `clothopt` binary every plan runs.
    pub clothopt: PathBuf,
    /// The set's scene files.
    pub scenes: Vec<SceneFile>,
    /// The time limit of each plan, s.
    pub time_limit: f64,
    search: SearchMode,
    scratch: PathBuf,
    results_dir: Option<PathBuf>,
}

impl PlanSet {
    /// The scenes of `dir` (`names` only, when given) for the flags `flags`; `tag` names the
    /// scratch folder. Creates `--results-dir`.
    pub fn new(
        tag: &str,
        dir: &Path,
        names: &[String],
        time_limit: f64,
        flags: &PlanFlags,
    ) -> Result<Self> {
        clothopt::validate::ensure_positive("--time-limit", time_limit)?;
        let clothopt = child::clothopt_binary(flags.clothopt.as_deref())?;
        let scenes = scene_files(dir, names)?;
        eprintln!("planning with {}", clothopt.display());
        if let Some(dir) = &flags.results_dir {
            std::fs::create_dir_all(dir)
                .with_context(|| format!("--results-dir: cannot create {}", dir.display()))?;
        }
        let scratch = std::env::temp_dir().join(format!("clothopt-{tag}-{}", std::process::id()));
        std::fs::create_dir_all(&scratch)
            .with_context(|| format!("cannot create {}", scratch.display()))?;
        Ok(PlanSet {
            clothopt,
            scenes,
            time_limit,
            search: flags.search,
            scratch,
            results_dir: flags.results_dir.clone(),
        })
    }

    /// One row per scene and variant, `plan` making each (an error becomes an `Error` row).
    pub fn rows<V: Copy, P>(
        &self,
        variants: &[V],
        name: impl Fn(V) -> &'static str,
        mut plan: impl FnMut(&SceneFile, V) -> Result<Outcome<P>>,
    ) -> Vec<Row<V, P>> {
        let mut rows = Vec::new();
        for scene in &self.scenes {
            for &variant in variants {
                eprintln!(
                    "{} ({}): planning, at most {} s …",
                    scene.name,
                    name(variant),
                    self.time_limit
                );
                let outcome = plan(scene, variant).unwrap_or_else(|e| Outcome::Error {
                    message: last_line(&format!("{e:#}")),
                });
                rows.push(Row {
                    scene: scene.name.clone(),
                    variant,
                    outcome,
                });
            }
        }
        rows
    }

    /// Plans `scene` as `variant` (its JSON; `None`: the file as it is) in a `clothopt optimize`
    /// child: the result, `optimize`'s exit code, the child's wall seconds and where the result
    /// was kept (`--results-dir`).
    pub fn plan(
        &self,
        scene: &SceneFile,
        variant: Option<Value>,
        variant_name: &str,
    ) -> Result<(PlanResult, i32, f64, Option<PathBuf>)> {
        let base = scene.path.parent().unwrap_or(Path::new("."));
        let stem = format!("{}.{variant_name}", scene.name);
        let file = match variant {
            None => scene.path.clone(),
            Some(mut value) => {
                absolute_files(&mut value, base)?;
                let path = self.scratch.join(format!("{stem}.json"));
                clothopt::output::write_json_atomic(&path, &value)?;
                path
            }
        };
        let result_path = match &self.results_dir {
            Some(dir) => dir.join(format!("{stem}.json")),
            None => self.scratch.join(format!("{stem}.result.json")),
        };
        let what = format!("clothopt optimize {} ({variant_name})", scene.name);
        let (result, exit_code, wall_s) = child::plan_scene(
            &self.clothopt,
            &file,
            self.time_limit,
            self.search,
            &result_path,
            &what,
        )?;
        let kept = self.results_dir.is_some();
        if !kept {
            let _ = std::fs::remove_file(&result_path);
        }
        Ok((result, exit_code, wall_s, kept.then_some(result_path)))
    }
}

/// The scene `text` (files relative to `base`) when the simulator takes it — it loads,
/// validates and compiles into a model — or its error on one line (the variant's
/// `Outcome::Unsupported`).
pub fn supported(text: &str, base: &Path) -> std::result::Result<cloth::Scene, String> {
    let scene = cloth::Scene::from_json_str_in(text, base).map_err(|e| one_line(&e))?;
    cloth::Model::from_scene(&scene).map_err(|e| one_line(&e))?;
    Ok(scene)
}

/// Writes `{"settings": …, "rows": […]}` to `out` (atomically), when given.
pub fn write_rows(
    out: Option<&Path>,
    settings: &impl Serialize,
    rows: &impl Serialize,
) -> Result<()> {
    match out {
        Some(out) => write_json(
            out,
            &serde_json::json!({ "settings": settings, "rows": rows }),
        ),
        None => Ok(()),
    }
}

impl Drop for PlanSet {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.scratch);
    }
}
