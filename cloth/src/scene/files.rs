//! Reading the files a scene names (a mesh cloth, its target mesh, mesh obstacles: OBJ files),
//! relative to a base folder.

use std::path::Path;

use super::{invalid, Obstacle, Scene, SceneError};
use crate::obj::ObjMesh;
use crate::sdf::MeshSdf;

impl Scene {
    /// Reads every mesh obstacle's `file` relative to `base` (a path that is already absolute is
    /// kept) and checks it is a closed, consistently oriented mesh of non-degenerate triangles. An
    /// unreadable, malformed, open or non-manifold file is rejected naming `obstacles[i].file`
    /// and, where it can, the file's line.
    ///
    /// A mesh cloth (`cloth.mesh`) must be a consistently oriented, possibly open, manifold of
    /// non-degenerate triangles using every vertex; `task.target_mesh` must have as many vertices
    /// as the cloth and the same number of triangles.
    pub fn load_files(&mut self, base: &Path) -> Result<(), SceneError> {
        if let Some(file) = &self.cloth.mesh {
            let path = base.join(file);
            let mesh = ObjMesh::read(&path)
                .and_then(|m| m.check_degenerate(&path).map(|()| m))
                .and_then(|m| m.check_cloth(&path).map(|()| m))
                .map_err(|e| invalid("cloth.mesh", e.to_string()))?;
            self.cloth.mesh_data = Some(mesh);
        }
        if let Some(file) = &self.task.target_mesh {
            let path = base.join(file);
            let target =
                ObjMesh::read(&path).map_err(|e| invalid("task.target_mesh", e.to_string()))?;
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
                let path = base.join(&spec.file);
                let field = format!("obstacles[{i}].file");
                let mesh = ObjMesh::read(&path).map_err(|e| invalid(&field, e.to_string()))?;
                mesh.check_degenerate(&path)
                    .and_then(|()| mesh.check_closed(&path))
                    .map_err(|e| invalid(&field, e.to_string()))?;
                spec.surface = Some(MeshSdf::new(mesh.vertices, mesh.triangles));
            }
        }
        Ok(())
    }
}
