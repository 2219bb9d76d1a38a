//! The built-in scenes, embedded from `examples/scenes/`.

pub(super) fn builtin_list() -> String {
    BUILTIN_NAMES
        .iter()
        .map(|(n, _)| *n)
        .collect::<Vec<_>>()
        .join(", ")
}

pub(super) const BUILTIN_NAMES: &[(&str, &str)] = &[
    (
        "u_obstacle",
        "Safety experiment: swing the cloth through a U-shaped opening of 18 spheres (safety constraint only)",
    ),
    (
        "swing",
        "Ablation: swing the hanging cloth so its bottom row reaches y = 1.0, z = 1.5 (no obstacle)",
    ),
    (
        "drop",
        "Ablation: lay the cloth flat on the ground plane z = 0 (a physical collider) by its four corners",
    ),
    (
        "fold",
        "Fold a towel (441-vertex mesh) in half on a table with friction and self-collision, beside a mug (safety)",
    ),
];

pub(super) const BUILTIN_SOURCES: [&str; 4] = [
    include_str!("../../../examples/scenes/u_obstacle.json"),
    include_str!("../../../examples/scenes/swing.json"),
    include_str!("../../../examples/scenes/drop.json"),
    include_str!("../../../examples/scenes/fold/fold.json"),
];

/// The files the built-in scenes name, by the name they use, with the folder they come from
/// (for messages).
pub(super) const BUILTIN_FILES: &[(&str, &str, &str)] = &[
    (
        "fold.obj",
        "examples/scenes/fold",
        include_str!("../../../examples/scenes/fold/fold.obj"),
    ),
    (
        "fold_folded.obj",
        "examples/scenes/fold",
        include_str!("../../../examples/scenes/fold/fold_folded.obj"),
    ),
];
