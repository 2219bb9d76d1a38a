//! Exports of a planned trajectory: dense way-points for a robot, and meshes for a viewer.

use std::fmt::Write;

/// Way-points of the control points, linearly interpolated between consecutive steps with
/// `per_step` samples per step (the step's start included, the final position appended), as
/// CSV: `step,fraction,c0_x,c0_y,c0_z,c1_x,…`.
///
/// `paths[k][t]` is control point `k` at step `t` (`T + 1` positions each); a path without
/// positions gives the header alone.
pub fn waypoints_csv(paths: &[Vec<[f64; 3]>], per_step: usize) -> String {
    let per_step = per_step.max(1);
    let steps = paths.first().map_or(0, |p| p.len().saturating_sub(1));
    let mut csv = String::from("step,fraction");
    for k in 0..paths.len() {
        let _ = write!(csv, ",c{k}_x,c{k}_y,c{k}_z");
    }
    csv.push('\n');
    if paths.iter().any(Vec::is_empty) {
        // No positions to interpolate: the header alone.
        return csv;
    }
    let mut row = |t: usize, s: f64| {
        let _ = write!(csv, "{t},{s}");
        for path in paths {
            let (a, b) = (path[t], path[(t + 1).min(path.len() - 1)]);
            for j in 0..3 {
                let _ = write!(csv, ",{}", a[j] + s * (b[j] - a[j]));
            }
        }
        csv.push('\n');
    };
    for t in 0..steps {
        for i in 0..per_step {
            row(t, i as f64 / per_step as f64);
        }
    }
    row(steps, 0.0);
    csv
}

/// One frame of a `rows × cols` grid cloth as a Wavefront OBJ mesh, triangulated like the
/// simulator's mesh (diagonal `(r,c)–(r+1,c+1)`).
pub fn obj_mesh(points: &[[f64; 3]], rows: usize, cols: usize) -> String {
    let mut obj = String::from("# clothopt cloth frame\n");
    for p in points {
        let _ = writeln!(obj, "v {} {} {}", p[0], p[1], p[2]);
    }
    for r in 0..rows.saturating_sub(1) {
        for c in 0..cols.saturating_sub(1) {
            let a = r * cols + c + 1;
            let (b, d, e) = (a + 1, a + cols, a + cols + 1);
            let _ = writeln!(obj, "f {a} {b} {e}");
            let _ = writeln!(obj, "f {a} {e} {d}");
        }
    }
    obj
}

/// One frame of a cloth of any shape as a Wavefront OBJ mesh: its points and `triangles`
/// (0-based particle indices, written 1-based).
pub fn obj_triangles(points: &[[f64; 3]], triangles: &[[usize; 3]]) -> String {
    let mut obj = String::from("# clothopt cloth frame\n");
    for p in points {
        let _ = writeln!(obj, "v {} {} {}", p[0], p[1], p[2]);
    }
    for t in triangles {
        let _ = writeln!(obj, "f {} {} {}", t[0] + 1, t[1] + 1, t[2] + 1);
    }
    obj
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn waypoints_interpolate_linearly_and_end_at_the_last_position() {
        let paths = vec![vec![[0.0, 0.0, 0.0], [1.0, 2.0, 4.0]]];
        let csv = waypoints_csv(&paths, 4);
        let lines: Vec<&str> = csv.lines().collect();
        assert_eq!(lines[0], "step,fraction,c0_x,c0_y,c0_z");
        assert_eq!(lines.len(), 1 + 4 + 1);
        assert_eq!(lines[2], "0,0.25,0.25,0.5,1");
        assert_eq!(lines[5], "1,0,1,2,4");
        // No positions: the header alone (it used to index past the end).
        assert_eq!(
            waypoints_csv(&[vec![]], 4),
            "step,fraction,c0_x,c0_y,c0_z\n"
        );
    }

    #[test]
    fn obj_has_a_vertex_per_particle_and_two_faces_per_cell() {
        let pts = vec![[0.0; 3]; 6];
        let obj = obj_mesh(&pts, 2, 3);
        assert_eq!(obj.lines().filter(|l| l.starts_with("v ")).count(), 6);
        assert_eq!(obj.lines().filter(|l| l.starts_with("f ")).count(), 4);
        assert!(obj.contains("f 1 2 5"));
    }
}
