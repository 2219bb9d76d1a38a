//! The scene files on disk (`examples/scenes/*.json`) and the canonical mesh/colouring conventions.
//!
//! The `REF_*` tables at the end were produced by the independent Python reference
//! (`anchors/jax_ref/scene.py`: `constraints(10)` and `greedy_colour`) for a 10 × 10 cloth, so these tests
//! pin the orderings that make results agree with other implementations of the paper.

use std::path::PathBuf;

use cloth::internals::GridMesh;
use cloth::internals::{greedy_coloring, independent_sets};
use cloth::scene::{Scene, SceneError};

fn scenes_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../examples/scenes")
}

#[test]
fn every_scene_file_loads_and_matches_its_builtin() {
    let mut names = Vec::new();
    for entry in std::fs::read_dir(scenes_dir()).expect("examples/scenes exists") {
        let mut path = entry.expect("dir entry").path();
        // A built-in that names files (a mesh cloth) is `NAME/NAME.json` beside them.
        if path.is_dir() {
            let name = path.file_name().and_then(|n| n.to_str()).unwrap_or("");
            if Scene::builtin(name).is_err() {
                continue;
            }
            path = path.join(format!("{name}.json"));
        }
        if path.extension().and_then(|e| e.to_str()) != Some("json") {
            continue;
        }
        let scene = Scene::load(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        let stem = path
            .file_stem()
            .and_then(|s| s.to_str())
            .expect("utf-8 name");
        assert_eq!(scene.name, stem, "scene name matches its file name");
        assert_eq!(Scene::builtin(stem).expect("file is a built-in"), scene);
        names.push(stem.to_string());
    }
    names.sort();
    let mut builtins: Vec<String> = Scene::builtin_names()
        .iter()
        .map(|(n, _)| n.to_string())
        .collect();
    builtins.sort();
    assert_eq!(
        names, builtins,
        "every file is built in and every built-in has a file"
    );
}

#[test]
fn saved_scene_loads_back_equal() {
    let dir = std::env::temp_dir().join(format!("cloth-scene-files-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    for &(name, _) in Scene::builtin_names() {
        let scene = Scene::builtin(name).expect("builtin");
        if scene.cloth.is_mesh() {
            // Its OBJ files go beside it.
            for entry in std::fs::read_dir(scenes_dir().join(name)).expect("its folder") {
                let from = entry.expect("dir entry").path();
                if from.extension().and_then(|e| e.to_str()) == Some("obj") {
                    std::fs::copy(&from, dir.join(from.file_name().unwrap())).expect("copy");
                }
            }
        }
        let path = dir.join(format!("{name}.json"));
        std::fs::write(&path, scene.to_json_pretty()).expect("write");
        assert_eq!(Scene::load(&path).expect("load"), scene, "{name}");
    }
    std::fs::remove_dir_all(&dir).expect("cleanup");
}

#[test]
fn load_reports_the_path_of_a_missing_file() {
    let path = scenes_dir().join("no_such_scene.json");
    match Scene::load(&path) {
        Err(e @ SceneError::Io { .. }) => assert!(e.to_string().contains("no_such_scene.json")),
        other => panic!("expected SceneError::Io, got {other:?}"),
    }
}

#[test]
fn mesh_orderings_match_the_reference() {
    let mesh = Scene::builtin("u_obstacle").expect("builtin").mesh();
    assert_eq!(mesh.stretch_edges(), REF_STRETCH.to_vec());
    assert_eq!(mesh.bending_pairs(), REF_BENDING.to_vec());
}

#[test]
fn colouring_matches_the_reference() {
    let mesh = GridMesh::new(10, 10);
    let n = mesh.n_particles();
    let cs = greedy_coloring(&mesh.stretch_edges(), n);
    let cb = greedy_coloring(&mesh.bending_pairs(), n);
    assert_eq!(cs, REF_STRETCH_COLOURS.to_vec());
    assert_eq!(cb, REF_BENDING_COLOURS.to_vec());
    let sizes = |sets: Vec<Vec<usize>>| sets.iter().map(Vec::len).collect::<Vec<_>>();
    assert_eq!(sizes(independent_sets(&cs)), vec![50, 50, 48, 34, 43, 36]);
    assert_eq!(sizes(independent_sets(&cb)), vec![46, 42, 40, 42, 32, 23]);
}

#[rustfmt::skip]
const REF_STRETCH: [[usize; 2]; 261] = [
    [0, 1], [1, 2], [2, 3], [3, 4], [4, 5], [5, 6], [6, 7], [7, 8], [8, 9], [10, 11], [11, 12],
    [12, 13], [13, 14], [14, 15], [15, 16], [16, 17], [17, 18], [18, 19], [20, 21], [21, 22],
    [22, 23], [23, 24], [24, 25], [25, 26], [26, 27], [27, 28], [28, 29], [30, 31], [31, 32],
    [32, 33], [33, 34], [34, 35], [35, 36], [36, 37], [37, 38], [38, 39], [40, 41], [41, 42],
    [42, 43], [43, 44], [44, 45], [45, 46], [46, 47], [47, 48], [48, 49], [50, 51], [51, 52],
    [52, 53], [53, 54], [54, 55], [55, 56], [56, 57], [57, 58], [58, 59], [60, 61], [61, 62],
    [62, 63], [63, 64], [64, 65], [65, 66], [66, 67], [67, 68], [68, 69], [70, 71], [71, 72],
    [72, 73], [73, 74], [74, 75], [75, 76], [76, 77], [77, 78], [78, 79], [80, 81], [81, 82],
    [82, 83], [83, 84], [84, 85], [85, 86], [86, 87], [87, 88], [88, 89], [90, 91], [91, 92],
    [92, 93], [93, 94], [94, 95], [95, 96], [96, 97], [97, 98], [98, 99], [0, 10], [1, 11], [2, 12],
    [3, 13], [4, 14], [5, 15], [6, 16], [7, 17], [8, 18], [9, 19], [10, 20], [11, 21], [12, 22],
    [13, 23], [14, 24], [15, 25], [16, 26], [17, 27], [18, 28], [19, 29], [20, 30], [21, 31],
    [22, 32], [23, 33], [24, 34], [25, 35], [26, 36], [27, 37], [28, 38], [29, 39], [30, 40],
    [31, 41], [32, 42], [33, 43], [34, 44], [35, 45], [36, 46], [37, 47], [38, 48], [39, 49],
    [40, 50], [41, 51], [42, 52], [43, 53], [44, 54], [45, 55], [46, 56], [47, 57], [48, 58],
    [49, 59], [50, 60], [51, 61], [52, 62], [53, 63], [54, 64], [55, 65], [56, 66], [57, 67],
    [58, 68], [59, 69], [60, 70], [61, 71], [62, 72], [63, 73], [64, 74], [65, 75], [66, 76],
    [67, 77], [68, 78], [69, 79], [70, 80], [71, 81], [72, 82], [73, 83], [74, 84], [75, 85],
    [76, 86], [77, 87], [78, 88], [79, 89], [80, 90], [81, 91], [82, 92], [83, 93], [84, 94],
    [85, 95], [86, 96], [87, 97], [88, 98], [89, 99], [0, 11], [1, 12], [2, 13], [3, 14], [4, 15],
    [5, 16], [6, 17], [7, 18], [8, 19], [10, 21], [11, 22], [12, 23], [13, 24], [14, 25], [15, 26],
    [16, 27], [17, 28], [18, 29], [20, 31], [21, 32], [22, 33], [23, 34], [24, 35], [25, 36],
    [26, 37], [27, 38], [28, 39], [30, 41], [31, 42], [32, 43], [33, 44], [34, 45], [35, 46],
    [36, 47], [37, 48], [38, 49], [40, 51], [41, 52], [42, 53], [43, 54], [44, 55], [45, 56],
    [46, 57], [47, 58], [48, 59], [50, 61], [51, 62], [52, 63], [53, 64], [54, 65], [55, 66],
    [56, 67], [57, 68], [58, 69], [60, 71], [61, 72], [62, 73], [63, 74], [64, 75], [65, 76],
    [66, 77], [67, 78], [68, 79], [70, 81], [71, 82], [72, 83], [73, 84], [74, 85], [75, 86],
    [76, 87], [77, 88], [78, 89], [80, 91], [81, 92], [82, 93], [83, 94], [84, 95], [85, 96],
    [86, 97], [87, 98], [88, 99],
];

#[rustfmt::skip]
const REF_BENDING: [[usize; 2]; 225] = [
    [0, 21], [1, 22], [2, 23], [3, 24], [4, 25], [5, 26], [6, 27], [7, 28], [8, 29], [10, 31],
    [11, 32], [12, 33], [13, 34], [14, 35], [15, 36], [16, 37], [17, 38], [18, 39], [20, 41],
    [21, 42], [22, 43], [23, 44], [24, 45], [25, 46], [26, 47], [27, 48], [28, 49], [30, 51],
    [31, 52], [32, 53], [33, 54], [34, 55], [35, 56], [36, 57], [37, 58], [38, 59], [40, 61],
    [41, 62], [42, 63], [43, 64], [44, 65], [45, 66], [46, 67], [47, 68], [48, 69], [50, 71],
    [51, 72], [52, 73], [53, 74], [54, 75], [55, 76], [56, 77], [57, 78], [58, 79], [60, 81],
    [61, 82], [62, 83], [63, 84], [64, 85], [65, 86], [66, 87], [67, 88], [68, 89], [70, 91],
    [71, 92], [72, 93], [73, 94], [74, 95], [75, 96], [76, 97], [77, 98], [78, 99], [0, 12],
    [1, 13], [2, 14], [3, 15], [4, 16], [5, 17], [6, 18], [7, 19], [10, 22], [11, 23], [12, 24],
    [13, 25], [14, 26], [15, 27], [16, 28], [17, 29], [20, 32], [21, 33], [22, 34], [23, 35],
    [24, 36], [25, 37], [26, 38], [27, 39], [30, 42], [31, 43], [32, 44], [33, 45], [34, 46],
    [35, 47], [36, 48], [37, 49], [40, 52], [41, 53], [42, 54], [43, 55], [44, 56], [45, 57],
    [46, 58], [47, 59], [50, 62], [51, 63], [52, 64], [53, 65], [54, 66], [55, 67], [56, 68],
    [57, 69], [60, 72], [61, 73], [62, 74], [63, 75], [64, 76], [65, 77], [66, 78], [67, 79],
    [70, 82], [71, 83], [72, 84], [73, 85], [74, 86], [75, 87], [76, 88], [77, 89], [80, 92],
    [81, 93], [82, 94], [83, 95], [84, 96], [85, 97], [86, 98], [87, 99], [1, 10], [2, 11], [3, 12],
    [4, 13], [5, 14], [6, 15], [7, 16], [8, 17], [9, 18], [11, 20], [12, 21], [13, 22], [14, 23],
    [15, 24], [16, 25], [17, 26], [18, 27], [19, 28], [21, 30], [22, 31], [23, 32], [24, 33],
    [25, 34], [26, 35], [27, 36], [28, 37], [29, 38], [31, 40], [32, 41], [33, 42], [34, 43],
    [35, 44], [36, 45], [37, 46], [38, 47], [39, 48], [41, 50], [42, 51], [43, 52], [44, 53],
    [45, 54], [46, 55], [47, 56], [48, 57], [49, 58], [51, 60], [52, 61], [53, 62], [54, 63],
    [55, 64], [56, 65], [57, 66], [58, 67], [59, 68], [61, 70], [62, 71], [63, 72], [64, 73],
    [65, 74], [66, 75], [67, 76], [68, 77], [69, 78], [71, 80], [72, 81], [73, 82], [74, 83],
    [75, 84], [76, 85], [77, 86], [78, 87], [79, 88], [81, 90], [82, 91], [83, 92], [84, 93],
    [85, 94], [86, 95], [87, 96], [88, 97], [89, 98],
];

#[rustfmt::skip]
const REF_STRETCH_COLOURS: [usize; 261] = [
    0, 1, 0, 1, 0, 1, 0, 1, 0, 0, 1, 0, 1, 0, 1, 0, 1, 0, 0, 1, 0, 1, 0, 1, 0, 1, 0, 0, 1, 0, 1, 0,
    1, 0, 1, 0, 0, 1, 0, 1, 0, 1, 0, 1, 0, 0, 1, 0, 1, 0, 1, 0, 1, 0, 0, 1, 0, 1, 0, 1, 0, 1, 0, 0,
    1, 0, 1, 0, 1, 0, 1, 0, 0, 1, 0, 1, 0, 1, 0, 1, 0, 0, 1, 0, 1, 0, 1, 0, 1, 0, 1, 2, 2, 2, 2, 2,
    2, 2, 2, 1, 2, 3, 3, 3, 3, 3, 3, 3, 3, 2, 1, 2, 2, 2, 2, 2, 2, 2, 2, 1, 2, 3, 3, 3, 3, 3, 3, 3,
    3, 2, 1, 2, 2, 2, 2, 2, 2, 2, 2, 1, 2, 3, 3, 3, 3, 3, 3, 3, 3, 2, 1, 2, 2, 2, 2, 2, 2, 2, 2, 1,
    2, 3, 3, 3, 3, 3, 3, 3, 3, 2, 1, 2, 2, 2, 2, 2, 2, 2, 2, 1, 4, 4, 4, 4, 4, 4, 4, 4, 3, 4, 5, 5,
    5, 5, 5, 5, 5, 5, 4, 5, 4, 4, 4, 4, 4, 4, 4, 4, 5, 4, 5, 5, 5, 5, 5, 5, 4, 5, 4, 5, 4, 4, 4, 4,
    4, 4, 5, 4, 5, 4, 5, 5, 5, 5, 4, 5, 4, 5, 4, 5, 4, 4, 4, 4, 5, 4, 5, 4, 5, 4, 5, 5, 3, 5, 4, 5,
    4, 5, 4, 5, 4,
];

#[rustfmt::skip]
const REF_BENDING_COLOURS: [usize; 225] = [
    0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 1, 1, 1, 1, 1, 1, 1, 1, 0, 1, 1, 1, 1,
    1, 1, 1, 1, 0, 1, 0, 0, 0, 0, 0, 0, 0, 0, 1, 0, 0, 0, 0, 0, 0, 0, 0, 1, 0, 1, 1, 1, 1, 1, 1, 0,
    1, 0, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 2, 2, 2, 2, 2, 2, 2, 2, 2, 2, 3, 3, 3, 3, 3, 3,
    2, 2, 3, 3, 2, 2, 2, 2, 2, 2, 3, 3, 2, 2, 3, 3, 2, 2, 3, 3, 2, 2, 3, 3, 2, 2, 3, 3, 2, 2, 3, 3,
    2, 2, 3, 3, 2, 2, 3, 3, 0, 1, 0, 3, 0, 0, 0, 0, 3, 3, 3, 3, 3, 3, 3, 3, 2, 1, 4, 4, 4, 4, 4, 4,
    4, 3, 3, 5, 5, 5, 5, 5, 5, 4, 4, 3, 4, 4, 4, 4, 4, 5, 5, 4, 3, 5, 5, 5, 5, 4, 4, 5, 4, 3, 4, 4,
    4, 5, 5, 4, 5, 2, 3, 5, 5, 4, 4, 5, 4, 4, 2, 3, 4, 5, 5, 4, 5, 5, 4, 2, 2, 3, 4, 2, 2, 4, 3, 4,
    2,
];
