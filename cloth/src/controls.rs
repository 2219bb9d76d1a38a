//! A typed view of a control sequence, indexed by (step, gripper) instead of by hand.
//!
//! The optimizer works on the flat [`Controls`] tensor: `horizon` rows of `3·K` numbers, entry
//! `3k + j` of row `t` being component `j` of gripper `k`'s displacement during step `t + 1`
//! (see `docs/scene-format.md`). [`ControlsView`] reads and writes that tensor as displacement
//! vectors without spelling out the layout:
//!
//! ```
//! use cloth::ControlsView;
//! use cloth::Controls;
//! let mut u = Controls::zeros(4, 3 * 2); // 4 steps, 2 grippers
//! u.set_at(2, 1, [0.0, 0.1, 0.0]);
//! assert_eq!(u.at(2, 1), [0.0, 0.1, 0.0]);
//! assert_eq!(u.row(2)[3 * 1 + 1], 0.1);
//! let path = u.gripper_path(1, [0.0; 3]);
//! assert_eq!(path.len(), 5); // rest + one position per step
//! assert_eq!(path[4], [0.0, 0.1, 0.0]);
//! ```

use autodiff::Tensor;

/// Controls: one row per time step, `3 × n_controls` displacements per row.
pub type Controls = Tensor;

/// (step, gripper) access to a controls tensor; steps `t` count from 0 (row `t` acts during step
/// `t + 1`), grippers `k` in the scene's `controls` order. Out-of-range indices panic, as slice
/// indexing does.
pub trait ControlsView {
    /// Number of steps (rows).
    fn n_steps(&self) -> usize;
    /// Number of grippers (control particles): a row's length over 3.
    fn n_grippers(&self) -> usize;
    /// Index of component `j` of gripper `k` at step `t` in the flat data: `t·3K + 3k + j`.
    fn flat_index(&self, t: usize, k: usize, j: usize) -> usize;
    /// Gripper `k`'s displacement during step `t + 1`.
    fn at(&self, t: usize, k: usize) -> [f64; 3];
    /// Sets gripper `k`'s displacement during step `t + 1`.
    fn set_at(&mut self, t: usize, k: usize, displacement: [f64; 3]);
    /// The displacements of step `t`, one per gripper.
    fn step_displacements(&self, t: usize) -> Vec<[f64; 3]>;
    /// Every displacement as `(t, k, [dx, dy, dz])`, steps outer, grippers inner.
    fn displacements(&self) -> Box<dyn Iterator<Item = (usize, usize, [f64; 3])> + '_>;
    /// The nested form of files and results: `[t][k] = [dx, dy, dz]`.
    fn to_nested(&self) -> Vec<Vec<[f64; 3]>>;
    /// Gripper `k`'s positions from `start`: `start`, then after each step (`n_steps + 1` points).
    fn gripper_path(&self, k: usize, start: [f64; 3]) -> Vec<[f64; 3]>;
}

impl ControlsView for Controls {
    fn n_steps(&self) -> usize {
        self.rows()
    }

    fn n_grippers(&self) -> usize {
        self.cols() / 3
    }

    fn flat_index(&self, t: usize, k: usize, j: usize) -> usize {
        assert!(
            t < self.n_steps() && k < self.n_grippers() && j < 3,
            "controls index (step {t}, gripper {k}, component {j}) out of range ({} steps, {} grippers)",
            self.n_steps(),
            self.n_grippers()
        );
        t * self.cols() + 3 * k + j
    }

    fn at(&self, t: usize, k: usize) -> [f64; 3] {
        let i = self.flat_index(t, k, 0);
        let d = &self.data()[i..i + 3];
        [d[0], d[1], d[2]]
    }

    fn set_at(&mut self, t: usize, k: usize, displacement: [f64; 3]) {
        let i = self.flat_index(t, k, 0);
        self.data_mut()[i..i + 3].copy_from_slice(&displacement);
    }

    fn step_displacements(&self, t: usize) -> Vec<[f64; 3]> {
        (0..self.n_grippers()).map(|k| self.at(t, k)).collect()
    }

    fn displacements(&self) -> Box<dyn Iterator<Item = (usize, usize, [f64; 3])> + '_> {
        let k = self.n_grippers();
        Box::new((0..self.n_steps()).flat_map(move |t| (0..k).map(move |c| (t, c, self.at(t, c)))))
    }

    fn to_nested(&self) -> Vec<Vec<[f64; 3]>> {
        (0..self.n_steps())
            .map(|t| self.step_displacements(t))
            .collect()
    }

    fn gripper_path(&self, k: usize, start: [f64; 3]) -> Vec<[f64; 3]> {
        let mut p = start;
        let mut path = Vec::with_capacity(self.n_steps() + 1);
        path.push(p);
        for t in 0..self.n_steps() {
            let u = self.at(t, k);
            p = [p[0] + u[0], p[1] + u[1], p[2] + u[2]];
            path.push(p);
        }
        path
    }
}

/// A controls tensor from the nested form `[t][k] = [dx, dy, dz]` (every step with the same number
/// of grippers); `None` if the steps differ in length.
pub fn controls_from_steps(steps: &[Vec<[f64; 3]>]) -> Option<Controls> {
    let k = steps.first().map_or(0, Vec::len);
    if steps.iter().any(|s| s.len() != k) {
        return None;
    }
    let data = steps.iter().flatten().flatten().copied().collect();
    Some(Controls::new(steps.len(), 3 * k, data))
}

/// The `controls` of a JSON file in the nested form (a plan's result, or `{"controls": …}`).
///
/// # Errors
/// The file cannot be read or parsed, has no `controls` in the nested form, or its steps differ
/// in length; the message names the file.
pub fn controls_from_file(path: &std::path::Path) -> Result<Controls, String> {
    let name = path.display();
    let text = std::fs::read_to_string(path).map_err(|e| format!("{name}: {e}"))?;
    let file: serde_json::Value =
        serde_json::from_str(&text).map_err(|e| format!("{name}: {e}"))?;
    let steps: Vec<Vec<[f64; 3]>> = serde_json::from_value(file["controls"].clone())
        .map_err(|e| format!("{name}: controls: {e}"))?;
    controls_from_steps(&steps).ok_or(format!("{name}: the controls' steps differ in length"))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Controls whose entry `t·3K + 3k + j` is `100t + 10k + j`.
    fn numbered(steps: usize, grippers: usize) -> Controls {
        let data = (0..steps * grippers * 3)
            .map(|i| {
                let (t, r) = (i / (3 * grippers), i % (3 * grippers));
                (100 * t + 10 * (r / 3) + r % 3) as f64
            })
            .collect();
        Controls::new(steps, 3 * grippers, data)
    }

    #[test]
    fn the_view_matches_the_documented_layout() {
        let u = numbered(4, 3);
        assert_eq!((u.n_steps(), u.n_grippers()), (4, 3));
        assert_eq!(u.at(2, 1), [210.0, 211.0, 212.0]);
        assert_eq!(u.flat_index(3, 2, 1), 3 * 9 + 3 * 2 + 1);
        assert_eq!(u.step_displacements(1)[2], [120.0, 121.0, 122.0]);
        let all: Vec<_> = u.displacements().collect();
        assert_eq!(all.len(), 12);
        assert_eq!(all[5], (1, 2, [120.0, 121.0, 122.0]));
        let nested = u.to_nested();
        assert_eq!(controls_from_steps(&nested), Some(u.clone()));
        assert_eq!(nested[3][0], u.at(3, 0));
    }

    #[test]
    fn controls_from_a_file_name_the_file_when_ragged() {
        let dir = std::env::temp_dir().join(format!("cloth-controls-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let good = dir.join("plan.json");
        std::fs::write(
            &good,
            r#"{"status": "x", "controls": [[[1, 2, 3]], [[4, 5, 6]]]}"#,
        )
        .unwrap();
        let u = controls_from_file(&good).unwrap();
        assert_eq!(u.data(), &[1.0, 2.0, 3.0, 4.0, 5.0, 6.0]);
        let ragged = dir.join("ragged.json");
        std::fs::write(&ragged, r#"{"controls": [[[1, 2, 3]], []]}"#).unwrap();
        let e = controls_from_file(&ragged).unwrap_err();
        assert!(e.contains("ragged.json") && e.contains("differ"), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn set_writes_one_gripper_and_paths_accumulate() {
        let mut u = Controls::zeros(3, 6);
        u.set_at(1, 1, [1.0, 2.0, 3.0]);
        u.set_at(2, 1, [0.5, 0.0, -1.0]);
        assert_eq!(u.data().iter().filter(|v| **v != 0.0).count(), 5);
        assert_eq!(u.row(1)[3..6], [1.0, 2.0, 3.0]);
        assert_eq!(
            u.gripper_path(1, [10.0, 0.0, 0.0]),
            vec![
                [10.0, 0.0, 0.0],
                [10.0, 0.0, 0.0],
                [11.0, 2.0, 3.0],
                [11.5, 2.0, 2.0]
            ]
        );
        assert_eq!(u.gripper_path(0, [0.0; 3]), vec![[0.0; 3]; 4]);
        assert_eq!(controls_from_steps(&[vec![[0.0; 3]], vec![]]), None);
    }

    #[test]
    #[should_panic(expected = "out of range")]
    fn a_gripper_out_of_range_panics() {
        Controls::zeros(2, 6).at(0, 2);
    }
}
