//! Greedy graph colouring of constraints into independent sets.
//!
//! Two constraints conflict when they touch a common particle. A colouring assigns each constraint a colour
//! such that conflicting constraints get different colours; the constraints of one colour form an
//! *independent set* that can be projected in parallel. The colouring is greedy first-fit **in the given
//! order**, so it is fully deterministic: with the canonical orders of [`crate::mesh::GridMesh`] a
//! `10 × 10` cloth gives 6 stretch sets and 6 bending sets (stretch and bending coloured separately).

/// Greedy first-fit colouring: constraints are visited in the given order and each takes the smallest
/// colour not used by any **earlier** constraint that touches any of its particles.
///
/// `constraints[k]` lists the particles of constraint `k` (any arity; a repeated particle is harmless).
/// Returns one colour per constraint; colours are `0..K` with every colour in that range used.
///
/// # Panics
/// If a constraint references a particle index `>= n_particles` (a programming error: constraint lists
/// come from the mesh, not from user input).
pub fn greedy_coloring(constraints: &[impl AsRef<[usize]>], n_particles: usize) -> Vec<usize> {
    // colours already used by constraints touching each particle
    let mut used: Vec<Vec<usize>> = vec![Vec::new(); n_particles];
    // scratch: forbidden[c] is true while colouring one constraint
    let mut forbidden: Vec<bool> = Vec::new();
    let mut colors = Vec::with_capacity(constraints.len());
    for (k, constraint) in constraints.iter().enumerate() {
        let particles = constraint.as_ref();
        for &p in particles {
            assert!(
                p < n_particles,
                "constraint {k} references particle {p}, but there are only {n_particles} particles"
            );
            for &c in &used[p] {
                if c >= forbidden.len() {
                    forbidden.resize(c + 1, false);
                }
                forbidden[c] = true;
            }
        }
        let color = forbidden
            .iter()
            .position(|&f| !f)
            .unwrap_or(forbidden.len());
        for &p in particles {
            for &c in &used[p] {
                forbidden[c] = false;
            }
        }
        for &p in particles {
            if !used[p].contains(&color) {
                used[p].push(color);
            }
        }
        colors.push(color);
    }
    colors
}

/// Groups constraint indices by colour: entry `c` of the result lists, in increasing order, the indices
/// `k` with `colors[k] == c`, for `c = 0..K` where `K = max(colors) + 1` (empty input gives no sets).
/// A colour in `0..K` that no constraint uses yields an empty set (never the case for
/// [`greedy_coloring`]'s output).
pub fn independent_sets(colors: &[usize]) -> Vec<Vec<usize>> {
    let k = colors.iter().max().map_or(0, |&m| m + 1);
    let mut sets = vec![Vec::new(); k];
    for (i, &c) in colors.iter().enumerate() {
        sets[c].push(i);
    }
    sets
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::GridMesh;
    use proptest::prelude::*;

    /// Asserts that no two constraints of one set share a particle, and that every constraint appears once.
    fn assert_sets_independent<C: AsRef<[usize]>>(
        constraints: &[C],
        sets: &[Vec<usize>],
        n: usize,
    ) {
        let mut seen = vec![false; constraints.len()];
        let mut owner = vec![usize::MAX; n];
        for (s, set) in sets.iter().enumerate() {
            for &k in set {
                assert!(!seen[k], "constraint {k} in two sets");
                seen[k] = true;
                let mut ps: Vec<usize> = constraints[k].as_ref().to_vec();
                ps.sort_unstable();
                ps.dedup();
                for p in ps {
                    assert_ne!(owner[p], s, "set {s}: particle {p} touched twice");
                    owner[p] = s;
                }
            }
        }
        assert!(seen.iter().all(|&x| x), "every constraint is in some set");
    }

    /// First-fit minimality: a constraint of colour `c` has, for every smaller colour, an earlier
    /// conflicting constraint of that colour.
    fn assert_first_fit<C: AsRef<[usize]>>(constraints: &[C], colors: &[usize]) {
        for (k, &c) in colors.iter().enumerate() {
            let pk = constraints[k].as_ref();
            for smaller in 0..c {
                let blocked = (0..k).any(|j| {
                    colors[j] == smaller && constraints[j].as_ref().iter().any(|p| pk.contains(p))
                });
                assert!(
                    blocked,
                    "constraint {k} has colour {c} but colour {smaller} was free"
                );
            }
        }
    }

    #[test]
    fn ten_by_ten_gives_six_plus_six_sets() {
        let m = GridMesh::new(10, 10);
        let stretch = m.stretch_edges();
        let bend = m.bending_pairs();
        let cs = greedy_coloring(&stretch, m.n_particles());
        let cb = greedy_coloring(&bend, m.n_particles());
        let ss = independent_sets(&cs);
        let sb = independent_sets(&cb);
        assert_eq!(ss.len(), 6);
        assert_eq!(sb.len(), 6);
        assert_sets_independent(&stretch, &ss, 100);
        assert_sets_independent(&bend, &sb, 100);
        assert_first_fit(&stretch, &cs);
        assert_first_fit(&bend, &cb);
        // each horizontal row alternates 0,1,…; the first vertical edge [0,10] meets colour 0 at both ends
        assert_eq!(&cs[..9], &[0, 1, 0, 1, 0, 1, 0, 1, 0]);
        assert_eq!(&cs[9..18], &[0, 1, 0, 1, 0, 1, 0, 1, 0]);
        assert_eq!(cs[90], 1);
        let sizes: Vec<usize> = ss.iter().map(Vec::len).collect();
        assert_eq!(sizes.iter().sum::<usize>(), 261);
        let sizes: Vec<usize> = sb.iter().map(Vec::len).collect();
        assert_eq!(sizes.iter().sum::<usize>(), 225);
    }

    #[test]
    fn small_hand_checked_example() {
        // path 0-1-2-3 plus a triangle constraint {1,3,4}
        let cons: Vec<Vec<usize>> =
            vec![vec![0, 1], vec![1, 2], vec![2, 3], vec![1, 3, 4], vec![4]];
        let colors = greedy_coloring(&cons, 5);
        assert_eq!(colors, vec![0, 1, 0, 2, 0]);
        assert_eq!(
            independent_sets(&colors),
            vec![vec![0, 2, 4], vec![1], vec![3]]
        );
    }

    #[test]
    fn edge_cases() {
        let empty: Vec<[usize; 2]> = Vec::new();
        assert!(greedy_coloring(&empty, 0).is_empty());
        assert!(independent_sets(&[]).is_empty());
        // gaps give empty sets
        assert_eq!(independent_sets(&[2, 0]), vec![vec![1], vec![], vec![0]]);
        // a constraint repeating a particle does not conflict with itself
        assert_eq!(greedy_coloring(&[[3, 3], [3, 1]], 4), vec![0, 1]);
        // disjoint constraints all get colour 0
        assert_eq!(greedy_coloring(&[[0, 1], [2, 3], [4, 5]], 6), vec![0, 0, 0]);
    }

    #[test]
    #[should_panic(expected = "references particle 7")]
    fn out_of_range_particle_panics() {
        greedy_coloring(&[[0, 7]], 4);
    }

    fn constraint_lists() -> impl Strategy<Value = (usize, Vec<Vec<usize>>)> {
        (1usize..30).prop_flat_map(|n| {
            (
                Just(n),
                prop::collection::vec(prop::collection::vec(0..n, 1..5), 0..60),
            )
        })
    }

    proptest! {
        #[test]
        fn random_constraint_lists_are_properly_coloured((n, cons) in constraint_lists()) {
            let colors = greedy_coloring(&cons, n);
            prop_assert_eq!(colors.len(), cons.len());
            let sets = independent_sets(&colors);
            assert_sets_independent(&cons, &sets, n);
            assert_first_fit(&cons, &colors);
            // every colour 0..K is used
            prop_assert!(sets.iter().all(|s| !s.is_empty()));
            // sets are sorted by constraint index
            prop_assert!(sets.iter().all(|s| s.windows(2).all(|w| w[0] < w[1])));
            // deterministic
            prop_assert_eq!(greedy_coloring(&cons, n), colors);
        }

        #[test]
        fn random_meshes_are_properly_coloured(rows in 1usize..9, cols in 1usize..9) {
            let m = GridMesh::new(rows, cols);
            let n = m.n_particles();
            let stretch = m.stretch_edges();
            let bend = m.bending_pairs();
            let quads = m.dihedral_quads();
            for cons in [stretch, bend] {
                let colors = greedy_coloring(&cons, n);
                let sets = independent_sets(&colors);
                assert_sets_independent(&cons, &sets, n);
                assert_first_fit(&cons, &colors);
                prop_assert_eq!(greedy_coloring(&cons, n), colors);
            }
            let colors = greedy_coloring(&quads, n);
            assert_sets_independent(&quads, &independent_sets(&colors), n);
            assert_first_fit(&quads, &colors);
        }
    }
}
