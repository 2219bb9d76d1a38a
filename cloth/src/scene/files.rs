//! Reading the files a scene names (a mesh cloth, its target mesh, mesh obstacles: OBJ files),
//! relative to a base folder.

use std::path::{Path, PathBuf};

use super::builtin::BUILTIN_FILES;
use super::{invalid, Obstacle, Scene, SceneError};
use crate::obj::{ObjError, ObjMesh};
use crate::sdf::MeshSdf;

/// Where the files a scene names are read from.
pub(super) enum Source<'a> {
    /// A folder (the scene file's, or the working directory).
    Folder(&'a Path),
    /// The files embedded with the built-in scenes.
    Builtin,
}

impl Source<'_> {
    /// The path `file` stands for (in messages) and the mesh read from it.
    fn read(&self, file: &str) -> (PathBuf, Result<ObjMesh, ObjError>) {
        match self {
            Source::Folder(base) => {
                let path = base.join(file);
                let mesh = ObjMesh::read(&path);
                (path, mesh)
            }
            Source::Builtin => match BUILTIN_FILES.iter().find(|(name, _, _)| *name == file) {
                Some((name, folder, text)) => {
                    let path = Path::new(folder).join(name);
                    let mesh = ObjMesh::parse(text, &path);
                    (path, mesh)
                }
                None => {
                    let path = PathBuf::from(file);
                    let source = std::io::Error::new(
                        std::io::ErrorKind::NotFound,
                        "not among the built-in scenes' files",
                    );
                    let err = ObjError::Io {
                        path: path.clone(),
                        source,
                    };
                    (path, Err(err))
                }
            },
        }
    }
}

impl Scene {
    /// Reads every mesh obstacle's `file` relative to `base` (a path that is already absolute is
    /// kept) and checks it is a closed, consistently oriented mesh of non-degenerate triangles. An
    /// unreadable, malformed, open or non-manifold file is rejected naming `obstacles[i].file`
    /// and, where it can, the file's line.
    ///
    /// A mesh cloth (`cloth.mesh`) must be a consistently oriented, possibly open, manifold of
    /// non-degenerate triangles using every vertex; `task.target_mesh` must have as many vertices
    /// as the cloth and the same number of triangles; `cloth.initial_state.obj`'s vertices are the
    /// cloth's positions at step 0 (its faces are not read).
    pub fn load_files(&mut self, base: &Path) -> Result<(), SceneError> {
        self.load_files_from(&Source::Folder(base))
    }

    /// [`Scene::load_files`] from `source`.
    pub(super) fn load_files_from(&mut self, source: &Source<'_>) -> Result<(), SceneError> {
        if let Some(file) = &self.cloth.mesh {
            let (path, mesh) = source.read(file);
            let mesh = mesh
                .and_then(|m| m.check_degenerate(&path).map(|()| m))
                .and_then(|m| m.check_cloth(&path).map(|()| m))
                .map_err(|e| invalid("cloth.mesh", e.to_string()))?;
            self.cloth.mesh_data = Some(mesh);
        }
        if let Some(state) = &mut self.cloth.initial_state {
            // With another source beside it, validation names the conflict instead.
            let alone = state.positions.is_none() && state.recipe.is_none();
            if let Some(file) = state.obj.as_ref().filter(|_| alone) {
                let (_, mesh) = source.read(file);
                let mesh = mesh.map_err(|e| invalid("cloth.initial_state.obj", e.to_string()))?;
                state.obj_data = Some(mesh.vertices);
            }
        }
        if let Some(file) = &self.task.target_mesh {
            let (path, target) = source.read(file);
            let target = target.map_err(|e| invalid("task.target_mesh", e.to_string()))?;
            if let Some(cloth) = &self.cloth.mesh_data {
                let (n, m) = (target.vertices.len(), cloth.vertices.len());
                if n != m {
                    return Err(invalid(
                        "task.target_mesh",
                        format!("`{}` has {n} vertices, the cloth (cloth.mesh) has {m}: a target mesh needs the cloth's topology", path.display()),
                    ));
                }
                let (n, m) = (target.triangles.len(), cloth.triangles.len());
                if n != m {
                    return Err(invalid(
                        "task.target_mesh",
                        format!("`{}` has {n} triangles, the cloth (cloth.mesh) has {m}: a target mesh needs the cloth's topology", path.display()),
                    ));
                }
            }
            self.task.target_mesh_data = Some(target.vertices);
        }
        for (i, obstacle) in self.obstacles.iter_mut().enumerate() {
            if let Obstacle::Mesh(spec) = obstacle {
                let (path, mesh) = source.read(&spec.file);
                let field = format!("obstacles[{i}].file");
                let mesh = mesh.map_err(|e| invalid(&field, e.to_string()))?;
                mesh.check_degenerate(&path)
                    .and_then(|()| mesh.check_closed(&path))
                    .map_err(|e| invalid(&field, e.to_string()))?;
                spec.surface = Some(MeshSdf::new(mesh.vertices, mesh.triangles));
            }
        }
        Ok(())
    }
}
