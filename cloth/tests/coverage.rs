//! Normalized coverage (`Model::coverage`): shapes of known area.

use autodiff::Tensor;
use cloth::{Model, Scene};

/// A flat `n × n` square cloth of side 1 lying in the plane `z = 0.5`, gravity `−z`, no
/// colliders; `Model::start` is its rest state.
fn flat_square(n: usize) -> Model {
    let text = format!(
        r#"{{"name": "sq", "cloth": {{"rows": {n}, "cols": {n}, "top_left": [0, 0, 0.5],
            "right": [1, 0, 0], "down": [0, 1, 0]}},
          "material": {{"stretch": 1000}}, "physics": {{"dt": 0.1, "gravity": [0, 0, -9.8]}},
          "controls": [[0, 0]],
          "task": {{"horizon": 1, "targets": [{{"particle": [0, 0], "position": [0, 0, 0]}}],
                    "alpha": 0, "beta": 0, "initial_controls": "zeros"}}}}"#
    );
    Model::from_scene(&Scene::from_json_str(&text).unwrap()).unwrap()
}

/// `x` with every point mapped by `f`.
fn mapped(x: &Tensor, f: impl Fn([f64; 3]) -> [f64; 3]) -> Tensor {
    let data = x
        .data()
        .chunks_exact(3)
        .flat_map(|p| f([p[0], p[1], p[2]]))
        .collect();
    Tensor::new(x.rows(), 3, data)
}

#[test]
fn a_flat_square_covers_one_and_folded_in_half_one_half() {
    for n in [3, 7, 15] {
        let m = flat_square(n);
        assert!((m.rest_area() - 1.0).abs() < 1e-12);
        let c = m.coverage(&m.start).unwrap();
        assert!((c - 1.0).abs() < 1e-12, "n = {n}: {c}");
        // Folded over the line y = 0.5, where the middle row lies (n odd): the rows beyond it
        // turned onto those before it, one layer 1 mm above the other.
        let folded = mapped(&m.start, |[x, y, z]| {
            if y > 0.5 {
                [x, 1.0 - y, z + 0.001]
            } else {
                [x, y, z]
            }
        });
        let c = m.coverage(&folded).unwrap();
        assert!((c - 0.5).abs() < 1e-12, "n = {n}: {c}");
        // Folded again (quarter) and lifted: a quarter, whatever the height.
        let quarter = mapped(&folded, |[x, y, z]| {
            if x > 0.5 {
                [1.0 - x, y, z + 3.0]
            } else {
                [x, y, z]
            }
        });
        let c = m.coverage(&quarter).unwrap();
        assert!((c - 0.25).abs() < 1e-12, "n = {n}: {c}");
    }
}

#[test]
fn coverage_is_the_shadow_along_gravity() {
    let m = flat_square(9);
    // Turned 45° in its plane: the same area, to the grid's resolution (a cell along the outline).
    let (c, s) = (
        std::f64::consts::FRAC_1_SQRT_2,
        std::f64::consts::FRAC_1_SQRT_2,
    );
    let turned = mapped(&m.start, |[x, y, z]| [c * x - s * y, s * x + c * y, z]);
    let cov = m.coverage(&turned).unwrap();
    assert!((cov - 1.0).abs() < 4.0 * 1.5 / 1024.0, "{cov}");
    // Tilted by 60° about the x axis: its shadow is cos 60° = 0.5 of it.
    let tilted = mapped(&m.start, |[x, y, z]| {
        let a = std::f64::consts::FRAC_PI_3;
        [x, y * a.cos(), z + y * a.sin()]
    });
    let cov = m.coverage(&tilted).unwrap();
    assert!((cov - 0.5).abs() < 1e-9, "{cov}");
    // Hanging vertically: no shadow.
    let hanging = mapped(&m.start, |[x, y, _]| [x, 0.0, y]);
    assert_eq!(m.coverage(&hanging), Some(0.0));
    // Crumpled into a quarter of its side on each axis: about 1/16.
    let crumpled = mapped(&m.start, |[x, y, z]| {
        [0.25 * x, 0.25 * y, z + (7.0 * x).sin() * 0.01]
    });
    let cov = m.coverage(&crumpled).unwrap();
    assert!((cov - 0.0625).abs() < 1e-9, "{cov}");
}

#[test]
fn no_gravity_no_coverage() {
    let text = r#"{"name": "sq", "cloth": {"rows": 3, "cols": 3, "top_left": [0, 0, 0],
            "right": [1, 0, 0], "down": [0, 1, 0]},
          "material": {"stretch": 1000}, "physics": {"dt": 0.1, "gravity": [0, 0, 0]},
          "controls": [[0, 0]],
          "task": {"horizon": 1, "targets": [{"particle": [0, 0], "position": [0, 0, 0]}],
                    "alpha": 0, "beta": 0, "initial_controls": "zeros"}}"#;
    let m = Model::from_scene(&Scene::from_json_str(text).unwrap()).unwrap();
    assert_eq!(m.coverage(&m.start), None);
}
