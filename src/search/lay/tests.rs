//! The lay route's geometry, with numbers: the taut string over the obstacles, the surface tops, the
//! route without and with a rail, and the hang.

use super::*;
use cloth::sdf::{Capsule, Cuboid};

const UP: [f64; 3] = [0.0, 0.0, 1.0];

/// A 3 cm rail along x at y = −0.55, z = 1, and a 0.75 m table (|y| ≤ 0.4).
fn rail_and_table() -> (Union, Union) {
    let rail = Union {
        capsules: vec![Capsule {
            a: [-0.5, -0.55, 1.0],
            b: [0.5, -0.55, 1.0],
            radius: 0.015,
        }],
        ..Union::default()
    };
    let mut all = rail.clone();
    all.boxes
        .push(Cuboid::new([0.0, 0.0, 0.375], [0.6, 0.4, 0.375], None));
    (rail, all)
}

fn length(paths: &Paths, k: usize) -> f64 {
    paths
        .windows(2)
        .map(|w| (V::from(w[1][k]) - V::from(w[0][k])).norm())
        .sum()
}

#[test]
fn the_hull_is_the_taut_string_over_the_points() {
    let points = [
        (0.0, 1.2),
        (0.1, 1.4),
        (0.15, 1.45),
        (0.2, 1.4),
        (0.5, 1.1),
        (0.9, 1.15),
    ];
    let hull = upper_hull(&points);
    assert_eq!(
        hull,
        vec![(0.0, 1.2), (0.1, 1.4), (0.15, 1.45), (0.9, 1.15)]
    );
    // Above the same abscissa only the higher point counts, and the ends are kept: a lift
    // straight up at the start and a drop straight down at the end.
    let hull = upper_hull(&[(0.0, 1.0), (0.0, 1.5), (1.0, 1.5), (1.0, 1.2)]);
    assert_eq!(hull, vec![(0.0, 1.0), (0.0, 1.5), (1.0, 1.5), (1.0, 1.2)]);
    let hull = upper_hull(&[(0.0, 1.0), (0.5, 0.2), (1.0, 0.3), (1.0, 0.8)]);
    assert_eq!(hull, vec![(0.0, 1.0), (1.0, 0.8)]);
}

#[test]
fn surface_top_finds_the_rail_and_the_table_from_above() {
    let (rail, all) = rail_and_table();
    let up = V::from(UP);
    let range = (0.3, 2.0);
    // Over the rail's axis: its top, 1.015, raised by the margin.
    let top = surface_top(&rail, V::new(0.0, -0.55, 5.0), up, 0.04, range).unwrap();
    assert!((top - 1.055).abs() < 2e-4, "{top}");
    // 3 cm off the axis: on the circle of radius 0.055 about it.
    let top = surface_top(&rail, V::new(0.0, -0.52, 0.0), up, 0.04, range).unwrap();
    let expected = 1.0 + (0.055f64.powi(2) - 0.03f64.powi(2)).sqrt();
    assert!((top - expected).abs() < 2e-4, "{top} {expected}");
    // Over the table, the rail aside: its top at 0.75; beyond both, nothing.
    let top = surface_top(&all, V::new(0.1, 0.0, 0.0), up, 0.0, range).unwrap();
    assert!((top - 0.75).abs() < 2e-4, "{top}");
    assert!(surface_top(&all, V::new(0.0, -0.8, 0.0), up, 0.04, range).is_none());
}

#[test]
fn without_obstacles_the_route_carries_straight_to_the_touch_point_and_lays_back() {
    // One gripper from behind the table to the held edge's place, the free edge 0.4 ahead on
    // the table, the cloth hanging 0.4: touch point (0, 0.2, 1.15), then 45° back and down.
    let spec = LaySpec {
        starts: &[[0.0, -0.7, 1.2]],
        ends: &[[0.0, -0.2, 0.75]],
        free_targets: &[[0.0, 0.2, 0.75], [0.0, 0.0, 0.75]],
        up: UP,
        hang: 0.4,
        horizon: 16,
        max_step: Some(0.1),
        lead: 0.0,
    };
    let lay = lay_paths(&spec, |_| None).unwrap();
    assert_eq!(lay.touch, 10);
    let paths = lay.paths;
    assert_eq!(paths.len(), 17);
    assert_eq!(paths[0][0], [0.0, -0.7, 1.2]);
    assert_eq!(paths[16][0], [0.0, -0.2, 0.75]);
    // Length: the carry √(0.9² + 0.05²) = 0.901 in 10 equal steps, the touch point, and the
    // lay 0.4·√2 = 0.566 in 6 (9 and 7 would make a carry step of 0.1001).
    let (carry, lay) = ((0.81f64 + 0.0025).sqrt(), 0.4 * 2f64.sqrt());
    assert!(
        (length(&paths, 0) - carry - lay).abs() < 1e-9,
        "{}",
        length(&paths, 0)
    );
    let touch = V::from(paths[10][0]) - V::new(0.0, 0.2, 1.15);
    assert!(touch.norm() < 1e-12, "{touch}");
    for (t, w) in paths.windows(2).enumerate() {
        let step = (V::from(w[1][0]) - V::from(w[0][0])).norm();
        let expected = if t < 10 { carry / 10.0 } else { lay / 6.0 };
        assert!((step - expected).abs() < 1e-9, "{t}: {step}");
    }
    // Every point on one of the two segments: the carry's line, then y + 0.2 = z − 0.75.
    for p in &paths {
        let [x, y, z] = p[0];
        let on_carry = (z - (1.2 - 0.05 * (y + 0.7) / 0.9)).abs() < 1e-3;
        let on_lay = y <= 0.2 + 1e-9 && (y + 0.2 - (z - 0.75)).abs() < 1e-3;
        assert!(x == 0.0 && (on_carry || on_lay), "{p:?}");
    }
    // Fifteen steps of at most 0.1 could cover 1.467 m only with a step across the touch
    // point: no route.
    let short = LaySpec {
        horizon: 15,
        ..spec.clone()
    };
    assert!(lay_paths(&short, |_| None).is_none());
    // No free target off the grippers' ends horizontally: nothing to lay.
    let above = LaySpec {
        free_targets: &[[0.0, -0.2, 0.9]],
        ..spec
    };
    assert!(lay_paths(&above, |_| None).is_none());
}

#[test]
fn over_a_rail_the_hanging_cloth_clears_it_and_the_route_fits_twenty_steps() {
    // The bar scene's numbers: grippers 0.4 apart along x at y = −0.7, z = 1.2, ends at
    // y = −0.2 on the table, the free edge to y = +0.2, the cloth hanging 0.4.
    let (rail, all) = rail_and_table();
    let up = V::from(UP);
    let range = (0.3, 2.0);
    let floor = |q: V| {
        let a = surface_top(&rail, q, up, 0.04, range);
        a.into_iter()
            .chain(surface_top(&all, q, up, 0.0, range))
            .reduce(f64::max)
    };
    let spec = LaySpec {
        starts: &[[-0.2, -0.7, 1.2], [0.2, -0.7, 1.2]],
        ends: &[[-0.2, -0.2, 0.75], [0.2, -0.2, 0.75]],
        free_targets: &[[-0.2, 0.2, 0.75], [0.2, 0.2, 0.75], [0.0, 0.0, 0.75]],
        up: UP,
        hang: 0.4,
        horizon: 20,
        max_step: Some(0.1),
        lead: 0.0,
    };
    let lay = lay_paths(&spec, floor).unwrap();
    let (paths, touch) = (lay.paths, lay.touch);
    let total = length(&paths, 0);
    // Up to the hull over the rail (peak 1.455 at y = −0.55), forward and down to the touch
    // point (y = 0.2, z = 1.15), and the 0.566 m lay: 1.61 m, more than 10 steps of 0.1.
    assert!((1.55..1.7).contains(&total), "{total}");
    assert!(
        (length(&paths, 1) - total).abs() < 1e-12,
        "the grippers move together"
    );
    let peak = paths.iter().map(|p| p[0][2]).fold(f64::MIN, f64::max);
    let at_touch = V::from(paths[touch][0]) - V::new(-0.2, 0.2, 1.15);
    assert!(
        touch == 13 && at_touch.norm() < 1e-12,
        "{touch}: {at_touch}"
    );
    assert!((1.44..1.46).contains(&peak), "{peak}");
    // Wherever the hanging cloth is over the rail's margin, its lowest point clears it.
    for p in &paths {
        let [_, y, z] = p[0];
        if (y + 0.55).abs() <= 0.055 {
            let top = 1.0 + (0.055f64.powi(2) - (y + 0.55).powi(2)).sqrt();
            assert!(z - 0.4 >= top - 1e-3, "{p:?}");
        }
        // Never past the touch point's y = 0.2.
        assert!(y <= 0.2 + 1e-9, "{p:?}");
    }
    // Ten steps (the scene's first horizon) are too few for this motion.
    let short = LaySpec {
        horizon: 10,
        ..spec.clone()
    };
    assert!(lay_paths(&short, floor).is_none());
    // A lead of 0.38 (the cloth's lag) moves the touch point to y = 0.58: the route grows
    // to 2.33 m, too long for 20 steps of 0.1 and within 24.
    let lead = LaySpec {
        lead: 0.38,
        ..spec.clone()
    };
    assert!(lay_paths(&lead, floor).is_none());
    let lay = lay_paths(
        &LaySpec {
            horizon: 24,
            ..lead
        },
        floor,
    )
    .unwrap();
    let total = length(&lay.paths, 1);
    let at_touch = V::from(lay.paths[lay.touch][1]) - V::new(0.2, 0.58, 1.15);
    assert!(
        (2.3..2.36).contains(&total) && at_touch.norm() < 1e-12,
        "{total} {at_touch}"
    );
}

#[test]
fn the_hang_is_the_deepest_particle_below_the_grippers() {
    // Two held particles at z = 1 and a third 0.4 below their midpoint; in the second state
    // the cloth lies at their height.
    let hanging = Tensor::new(3, 3, vec![0.0, 0.0, 1.0, 0.4, 0.0, 1.0, 0.2, 0.0, 0.6]);
    let flat = Tensor::new(3, 3, vec![0.0, 0.0, 1.0, 0.4, 0.0, 1.0, 0.2, 0.4, 1.0]);
    let h = hang(&[hanging, flat.clone()], &[0, 1], V::from(UP));
    assert!((h - 0.4).abs() < 1e-12, "{h}");
    assert_eq!(hang(&[flat], &[0, 1], V::from(UP)), 0.0);
}
