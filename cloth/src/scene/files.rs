//! Reading the files a scene names (mesh obstacles' OBJ files), relative to a base folder.

use std::path::Path;

use super::{invalid, Obstacle, Scene, SceneError};
use crate::obj::ObjMesh;
use crate::sdf::MeshSdf;

impl Scene {
    /// Reads every mesh obstacle's `file` relative to `base` (a path that is already absolute is
    /// kept) and checks it is a closed, consistently oriented mesh of non-degenerate triangles. An
    /// unreadable, malformed, open or non-manifold file is rejected naming `obstacles[i].file`
    /// and, where it can, the file's line.
    pub fn load_files(&mut self, base: &Path) -> Result<(), SceneError> {
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
