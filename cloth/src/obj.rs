//! A reader for Wavefront OBJ triangle meshes: `v x y z` vertices and `f` faces (`i`, `i/t`,
//! `i//n`, `i/t/n`, negative indices relative to the end), polygons split into a fan of
//! triangles. Other statements (`vt`, `vn`, `o`, `g`, `s`, `usemtl`, `mtllib`, comments) are
//! ignored.
//!
//! Written here rather than taken from an OBJ crate so that vertex `k` is exactly the file's
//! `k`-th `v` line (scenes name cloth vertices by index) and every error names its line.

use std::path::{Path, PathBuf};

/// A triangle mesh read from an OBJ file.
#[derive(Clone, Debug, PartialEq)]
pub struct ObjMesh {
    /// Vertex positions, in file order.
    pub vertices: Vec<[f64; 3]>,
    /// Triangles as vertex indices (0-based), in file order.
    pub triangles: Vec<[usize; 3]>,
    /// The file line (1-based) of each triangle's face.
    pub triangle_lines: Vec<usize>,
}

/// Why an OBJ file cannot be used.
#[derive(Debug, thiserror::Error)]
pub enum ObjError {
    /// The file could not be read.
    #[error("cannot read `{}`: {source}", path.display())]
    Io {
        /// The path.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
    /// A statement is malformed or a value is bad.
    #[error("`{}` line {line}: {reason}", path.display())]
    Line {
        /// The path.
        path: PathBuf,
        /// 1-based line.
        line: usize,
        /// What is wrong.
        reason: String,
    },
    /// The mesh as a whole is unusable (no triangles, open, non-manifold, …).
    #[error("`{}`: {reason}", path.display())]
    Mesh {
        /// The path.
        path: PathBuf,
        /// What is wrong.
        reason: String,
    },
}

impl ObjMesh {
    /// Reads and parses `path`.
    pub fn read(path: &Path) -> Result<ObjMesh, ObjError> {
        let text = std::fs::read_to_string(path).map_err(|source| ObjError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        ObjMesh::parse(&text, path)
    }

    /// Parses OBJ text; `path` only names the file in errors. Rejects non-finite coordinates,
    /// indices out of range, faces of fewer than 3 vertices, repeated vertices in a face, and a
    /// file without triangles.
    pub fn parse(text: &str, path: &Path) -> Result<ObjMesh, ObjError> {
        let at = |line: usize, reason: String| ObjError::Line {
            path: path.to_path_buf(),
            line,
            reason,
        };
        let mut mesh = ObjMesh {
            vertices: Vec::new(),
            triangles: Vec::new(),
            triangle_lines: Vec::new(),
        };
        for (i, raw) in text.lines().enumerate() {
            let line = i + 1;
            let content = raw.split('#').next().unwrap_or("");
            let mut words = content.split_whitespace();
            match words.next() {
                Some("v") => {
                    let xs: Vec<&str> = words.collect();
                    if xs.len() < 3 {
                        return Err(at(
                            line,
                            format!("a vertex needs 3 coordinates, got {}", xs.len()),
                        ));
                    }
                    let mut v = [0.0; 3];
                    for k in 0..3 {
                        let x: f64 = xs[k]
                            .parse()
                            .map_err(|_| at(line, format!("`{}` is not a number", xs[k])))?;
                        if !x.is_finite() {
                            return Err(at(line, format!("vertex coordinate {x} is not finite")));
                        }
                        v[k] = x;
                    }
                    mesh.vertices.push(v);
                }
                Some("f") => {
                    let n = mesh.vertices.len();
                    let mut face = Vec::new();
                    for w in words {
                        let first = w.split('/').next().unwrap_or("");
                        let k: i64 = first
                            .parse()
                            .map_err(|_| at(line, format!("`{w}` is not a vertex index")))?;
                        let index = if k > 0 && (k as usize) <= n {
                            k as usize - 1
                        } else if k < 0 && k.unsigned_abs() as usize <= n {
                            n - k.unsigned_abs() as usize
                        } else {
                            return Err(at(
                                line,
                                format!("vertex index {k} out of range ({n} vertices so far)"),
                            ));
                        };
                        if face.contains(&index) {
                            return Err(at(
                                line,
                                format!("vertex {} repeated in one face", index + 1),
                            ));
                        }
                        face.push(index);
                    }
                    if face.len() < 3 {
                        return Err(at(
                            line,
                            format!("a face needs 3 vertices, got {}", face.len()),
                        ));
                    }
                    for k in 1..face.len() - 1 {
                        mesh.triangles.push([face[0], face[k], face[k + 1]]);
                        mesh.triangle_lines.push(line);
                    }
                }
                _ => {}
            }
        }
        if mesh.triangles.is_empty() {
            return Err(ObjError::Mesh {
                path: path.to_path_buf(),
                reason: "no faces".into(),
            });
        }
        Ok(mesh)
    }

    /// Rejects triangles of (near) zero area: `|e₁ × e₂| ≤ 1e-12 · |e₁|·|e₂|`.
    pub fn check_degenerate(&self, path: &Path) -> Result<(), ObjError> {
        for (t, tri) in self.triangles.iter().enumerate() {
            let [a, b, c] = tri.map(|v| nalgebra::Vector3::from(self.vertices[v]));
            let (e1, e2) = (b - a, c - a);
            if e1.cross(&e2).norm() <= 1e-12 * e1.norm() * e2.norm()
                || e1.norm() == 0.0
                || e2.norm() == 0.0
            {
                return Err(ObjError::Line {
                    path: path.to_path_buf(),
                    line: self.triangle_lines[t],
                    reason: format!("triangle {t} is degenerate (zero area)"),
                });
            }
        }
        Ok(())
    }

    /// Each undirected edge with the triangles that use it, in the order `(edge, [(triangle,
    /// directed as a→b)])`, sorted by edge.
    pub fn edge_uses(&self) -> std::collections::BTreeMap<[usize; 2], Vec<(usize, bool)>> {
        let mut uses: std::collections::BTreeMap<[usize; 2], Vec<(usize, bool)>> =
            Default::default();
        for (t, tri) in self.triangles.iter().enumerate() {
            for k in 0..3 {
                let (a, b) = (tri[k], tri[(k + 1) % 3]);
                uses.entry([a.min(b), a.max(b)])
                    .or_default()
                    .push((t, a < b));
            }
        }
        uses
    }

    /// Requires a closed, consistently oriented 2-manifold: every edge in exactly two triangles,
    /// traversed in opposite directions.
    pub fn check_closed(&self, path: &Path) -> Result<(), ObjError> {
        let err = |t: usize, reason: String| ObjError::Line {
            path: path.to_path_buf(),
            line: self.triangle_lines[t],
            reason,
        };
        for ([a, b], uses) in self.edge_uses() {
            let t = uses[0].0;
            match uses.len() {
                1 => {
                    return Err(err(t, format!(
                        "open mesh: edge {}–{} of triangle {t} has no neighbour (an obstacle mesh must be closed)",
                        a + 1,
                        b + 1
                    )))
                }
                2 if uses[0].1 == uses[1].1 => {
                    return Err(err(uses[1].0, format!(
                        "triangles {t} and {} traverse edge {}–{} in the same direction (inconsistent orientation)",
                        uses[1].0,
                        a + 1,
                        b + 1
                    )))
                }
                2 => {}
                n => {
                    return Err(err(t, format!(
                        "non-manifold: edge {}–{} is shared by {n} triangles",
                        a + 1,
                        b + 1
                    )))
                }
            }
        }
        Ok(())
    }
}

impl ObjMesh {
    /// Requires a cloth surface: every edge in one triangle (boundary) or two triangles traversed
    /// in opposite directions (a consistently oriented 2-manifold, possibly open), and every
    /// vertex in some triangle (a vertex in none would be a free particle).
    pub fn check_cloth(&self, path: &Path) -> Result<(), ObjError> {
        let err = |t: usize, reason: String| ObjError::Line {
            path: path.to_path_buf(),
            line: self.triangle_lines[t],
            reason,
        };
        for ([a, b], uses) in self.edge_uses() {
            match uses.len() {
                1 => {}
                2 if uses[0].1 == uses[1].1 => {
                    return Err(err(uses[1].0, format!(
                        "triangles {} and {} traverse edge {}–{} in the same direction (inconsistent orientation)",
                        uses[0].0,
                        uses[1].0,
                        a + 1,
                        b + 1
                    )))
                }
                2 => {}
                n => {
                    return Err(err(uses[2].0, format!(
                        "non-manifold: edge {}–{} is shared by {n} triangles",
                        a + 1,
                        b + 1
                    )))
                }
            }
        }
        let mut used = vec![false; self.vertices.len()];
        for tri in &self.triangles {
            for &v in tri {
                used[v] = true;
            }
        }
        if let Some(v) = used.iter().position(|u| !u) {
            return Err(ObjError::Mesh {
                path: path.to_path_buf(),
                reason: format!(
                    "vertex {} is in no triangle (a cloth vertex must belong to a face)",
                    v + 1
                ),
            });
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<ObjMesh, ObjError> {
        ObjMesh::parse(text, Path::new("t.obj"))
    }

    #[test]
    fn reads_faces_of_every_form() {
        let m = parse("# quad\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nf 1/1 2//3 3/1/2 -1\n")
            .unwrap();
        assert_eq!(m.vertices.len(), 4);
        assert_eq!(m.triangles, vec![[0, 1, 2], [0, 2, 3]]);
        assert_eq!(m.triangle_lines, vec![7, 7]);
    }

    #[test]
    fn errors_name_the_line() {
        let e = parse("v 0 0 0\nv 1 0 nan\n").unwrap_err().to_string();
        assert!(e.contains("line 2") && e.contains("not finite"), "{e}");
        let e = parse("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("line 4") && e.contains("out of range"), "{e}");
        let e = parse("v 0 0 0\n").unwrap_err().to_string();
        assert!(e.contains("no faces"), "{e}");
        let m = parse("v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n").unwrap();
        let e = m
            .check_degenerate(Path::new("t.obj"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("line 4") && e.contains("degenerate"), "{e}");
        let m = parse("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
        let e = m.check_closed(Path::new("t.obj")).unwrap_err().to_string();
        assert!(e.contains("open mesh"), "{e}");
    }

    #[test]
    fn cloth_checks_accept_open_sheets_and_name_bad_topology() {
        let path = Path::new("c.obj");
        let sheet = parse("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3\nf 1 3 4\n").unwrap();
        sheet.check_cloth(path).unwrap();
        let flipped = parse("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3\nf 1 4 3\n").unwrap();
        let e = flipped.check_cloth(path).unwrap_err().to_string();
        assert!(e.contains("line 6") && e.contains("same direction"), "{e}");
        let fan =
            parse("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 -1 0\nv 0 0 1\nf 1 2 3\nf 2 1 4\nf 1 2 5\n")
                .unwrap();
        let e = fan.check_cloth(path).unwrap_err().to_string();
        assert!(e.contains("line 8") && e.contains("non-manifold"), "{e}");
        let stray = parse("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 5 5 5\nf 1 2 3\n").unwrap();
        let e = stray.check_cloth(path).unwrap_err().to_string();
        assert!(e.contains("vertex 4 is in no triangle"), "{e}");
    }
}
