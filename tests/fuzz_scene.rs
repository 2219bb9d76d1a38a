//! Random and mutated scene JSON against the loader, and random controls against the simulator
//! (issue 7, item 4).
//!
//! Inputs start from the built-in scenes' JSON ([`Scene::to_json_pretty`]) and are mutated at the
//! value level (numbers replaced by boundary values — 0, ±1e-300, ±1e300, f64::MAX, 5e-324, huge
//! integers —, values replaced by another type, keys deleted, added or misspelt, elements dropped
//! or duplicated) and at the text level (truncated, a byte replaced). Properties:
//! - [`Scene::from_json_str`] never panics, and an error is one line;
//! - every accepted scene compiles ([`Model::from_scene`]);
//! - accepted scenes up to 400 particles and 1e5 projections per rollout simulate their initial
//!   guess and random controls (magnitudes 1e-3 to 1e6) without NaN: either every state, metric
//!   and gradient is finite, or the simulator returns [`ClothError::Diverged`] naming a step in
//!   `1..=T` and a particle in `0..N` (a rollout that leaves the range of `f64`).

mod common;
use cloth::{ClothError, Model, Scene};
use common::noise;
use proptest::prelude::*;
use serde_json::{Map, Value};

/// Particles above which an accepted scene is not simulated (kept fast).
const MAX_PARTICLES: usize = 400;
/// Projections per rollout (`per iteration × iterations × T`) above which it is not simulated.
const MAX_PROJECTIONS: usize = 100_000;

/// Boundary numbers a mutation substitutes.
const NUMBERS: &[f64] = &[
    0.0,
    -0.0,
    1.0,
    -1.0,
    2.0,
    0.5,
    3.0,
    10.0,
    1e-300,
    -1e-300,
    5e-324,
    1e-160,
    1e-15,
    1e15,
    1e154,
    1e300,
    -1e300,
    f64::MAX,
    f64::MIN,
    1e6,
    -1e6,
    0.1,
    1e-8,
];

/// JSON values of other types a mutation substitutes.
fn other_value(k: u64) -> Value {
    match k % 12 {
        0 => Value::Null,
        1 => Value::Bool(true),
        2 => Value::from("inf"),
        3 => Value::from("nan"),
        4 => Value::from("Infinity"),
        5 => Value::from("x"),
        6 => Value::Array(vec![]),
        7 => Value::Object(Map::new()),
        8 => serde_json::json!([1, 2, 3]),
        9 => serde_json::json!([[0, 0], [1, 1]]),
        10 => Value::from(u64::MAX),
        _ => Value::from(i64::MIN),
    }
}

/// Every JSON pointer in `v`, in document order.
fn pointers(v: &Value, at: String, out: &mut Vec<String>) {
    out.push(at.clone());
    match v {
        Value::Object(m) => {
            for (k, x) in m {
                pointers(x, format!("{at}/{k}"), out);
            }
        }
        Value::Array(a) => {
            for (i, x) in a.iter().enumerate() {
                pointers(x, format!("{at}/{i}"), out);
            }
        }
        _ => {}
    }
}

/// Splits a pointer into its parent and last token.
fn parent_of(p: &str) -> Option<(&str, &str)> {
    p.rfind('/').map(|i| (&p[..i], &p[i + 1..]))
}

/// One value-level mutation; `a`, `b` select where and what.
fn mutate(v: &mut Value, kind: u8, a: u64, b: u64) {
    let mut ps = Vec::new();
    pointers(v, String::new(), &mut ps);
    let numeric: Vec<&String> = ps
        .iter()
        .filter(|p| v.pointer(p).is_some_and(Value::is_number))
        .collect();
    match kind % 8 {
        // A number becomes a boundary value (most mutations: numbers carry the physics).
        0..=2 if !numeric.is_empty() => {
            let p = numeric[(a % numeric.len() as u64) as usize].clone();
            let x = NUMBERS[(b % NUMBERS.len() as u64) as usize];
            if let Some(slot) = v.pointer_mut(&p) {
                *slot = serde_json::Number::from_f64(x).map_or(Value::Null, Value::Number);
            }
        }
        // A number is scaled or becomes a small integer (sizes, indices, iterations).
        3 if !numeric.is_empty() => {
            let p = numeric[(a % numeric.len() as u64) as usize].clone();
            if let Some(slot) = v.pointer_mut(&p) {
                *slot = if b & 1 == 0 {
                    Value::from(b % 13)
                } else {
                    let x = slot.as_f64().unwrap_or(1.0) * [-1.0, 1e3, 1e-3, 7.5][(b % 4) as usize];
                    serde_json::Number::from_f64(x).map_or(Value::Null, Value::Number)
                };
            }
        }
        // Any value becomes another type.
        4 => {
            let p = ps[(a % ps.len() as u64) as usize].clone();
            if let Some(slot) = v.pointer_mut(&p) {
                *slot = other_value(b);
            }
        }
        // A key or an array element is removed.
        5 => {
            let p = ps[(a % ps.len() as u64) as usize].clone();
            if let Some((parent, last)) = parent_of(&p) {
                match v.pointer_mut(parent) {
                    Some(Value::Object(m)) => {
                        m.remove(last);
                    }
                    Some(Value::Array(arr)) => {
                        if let Ok(i) = last.parse::<usize>() {
                            if i < arr.len() {
                                arr.remove(i);
                            }
                        }
                    }
                    _ => {}
                }
            }
        }
        // An unknown key is added, or a key is misspelt, or an array element duplicated.
        6 => {
            let p = ps[(a % ps.len() as u64) as usize].clone();
            match v.pointer_mut(&p) {
                Some(Value::Object(m)) => {
                    if b & 1 == 0 {
                        m.insert("unexpected".into(), Value::from(1));
                    } else if let Some(k) = m.keys().nth((b as usize / 2) % m.len().max(1)).cloned()
                    {
                        if let Some(x) = m.remove(&k) {
                            m.insert(format!("{k}_"), x);
                        }
                    }
                }
                Some(Value::Array(arr)) if !arr.is_empty() => {
                    let i = (b % arr.len() as u64) as usize;
                    let x = arr[i].clone();
                    arr.push(x);
                }
                _ => {}
            }
        }
        // Grid size, horizon or iterations changes together with what depends on it being left
        // as it is (shape mismatches, indices out of range).
        _ => {
            let fields = [
                "/cloth/rows",
                "/cloth/cols",
                "/task/horizon",
                "/physics/iterations",
            ];
            let p = fields[(a % 4) as usize];
            if let Some(slot) = v.pointer_mut(p) {
                *slot = Value::from([0, 1, 2, 3, 5, 20, 1000][(b % 7) as usize]);
            }
        }
    }
}

/// A text-level mutation: truncate, or replace one byte.
fn mutate_text(text: &str, kind: u8, a: u64, b: u64) -> String {
    let bytes = text.as_bytes();
    let i = (a % bytes.len().max(1) as u64) as usize;
    match kind % 3 {
        0 => String::from_utf8_lossy(&bytes[..i]).into_owned(),
        1 => {
            let mut v = bytes.to_vec();
            if !v.is_empty() {
                v[i] = b"{}[],:\"0-.e9 x\\"[(b % 15) as usize];
            }
            String::from_utf8_lossy(&v).into_owned()
        }
        _ => text.to_string(),
    }
}

/// True if `v` holds a number beyond 1e100 or a nonzero one below 1e-100 in magnitude.
fn has_extreme_number(v: &Value) -> bool {
    match v {
        Value::Number(x) => x
            .as_f64()
            .is_some_and(|x| x.abs() > 1e100 || (x != 0.0 && x.abs() < 1e-100)),
        Value::Array(a) => a.iter().any(has_extreme_number),
        Value::Object(m) => m.values().any(has_extreme_number),
        _ => false,
    }
}

/// What happened to one input (for the statistics printed at the end).
#[derive(Debug, Default)]
struct Outcome {
    rejected: bool,
    too_big: bool,
    finite_rollouts: usize,
    diverged: usize,
}

/// Loads `text`; if accepted, compiles and simulates it. Panics (failing the property) on any
/// violation of the properties in the module docs.
fn check(text: &str, control_seed: u64) -> Outcome {
    let mut outcome = Outcome::default();
    let scene = match Scene::from_json_str(text) {
        Ok(s) => s,
        Err(e) => {
            let msg = e.to_string();
            assert!(!msg.contains('\n'), "multi-line error: {msg}");
            assert!(!msg.is_empty());
            outcome.rejected = true;
            return outcome;
        }
    };
    // Validated scenes read back (the writer and the reader agree).
    let back = Scene::from_json_str(&scene.to_json_pretty())
        .unwrap_or_else(|e| panic!("an accepted scene does not read back: {e}"));
    assert_eq!(back.n_particles(), scene.n_particles());
    if scene.n_particles() > MAX_PARTICLES {
        outcome.too_big = true;
        return outcome;
    }
    let model = Model::from_scene(&scene)
        .unwrap_or_else(|e| panic!("an accepted scene does not compile: {e}"));
    let horizon = model.task.horizon;
    let per_rollout = model
        .projections_per_iteration()
        .max(1)
        .saturating_mul(model.iterations)
        .saturating_mul(horizon);
    if per_rollout > MAX_PROJECTIONS {
        outcome.too_big = true;
        return outcome;
    }
    let n = model.n_particles();
    let width = 3 * model.n_controls();
    let extreme = has_extreme_number(&serde_json::from_str(text).unwrap_or(Value::Null));
    let guess = clothopt::plan::initial_controls(&scene, &model)
        .unwrap_or_else(|e| panic!("the validated initial guess does not fit: {e}"));
    let scale = [1e-3, 0.05, 1.0, 1e6][(control_seed % 4) as usize];
    let random = autodiff::Tensor::new(
        horizon,
        width,
        noise(control_seed, horizon * width)
            .into_iter()
            .map(|x| scale * x)
            .collect(),
    );
    for u in [guess, random] {
        match model.evaluate(&u, scene.task.delta, true) {
            Ok(ev) => {
                for (t, x) in ev.states.iter().enumerate() {
                    assert!(x.is_finite(), "state {t} not finite but no error");
                }
                let m = ev.metrics;
                for (k, v) in [("L", m.l), ("G", m.g), ("T", m.t), ("E", m.e), ("C", m.c)] {
                    assert!(v.is_finite(), "{k} = {v} after a finite rollout\n{text}");
                }
                assert!(!m.min_sdf.is_nan() && !m.min_sdf_swept.is_nan());
                assert!(
                    ev.grad_l.unwrap().is_finite(),
                    "dL/dU not finite after a finite rollout (metrics {m:?})\n{text}"
                );
                assert!(ev.grad_c.unwrap().is_finite(), "dC/dU not finite\n{text}");
                outcome.finite_rollouts += 1;
            }
            Err(e @ ClothError::Diverged { .. }) | Err(e @ ClothError::NonFinite { .. }) => {
                let msg = e.to_string();
                assert!(!msg.contains('\n'), "{msg}");
                match e {
                    ClothError::Diverged {
                        step,
                        particle,
                        position,
                    } => {
                        assert!((1..=horizon).contains(&step), "step {step} of {horizon}");
                        assert!(particle < n, "particle {particle} of {n}");
                        assert!(position.iter().any(|v| !v.is_finite()));
                    }
                    _ => assert!(msg.contains("is not finite"), "{msg}"),
                }
                // Only values near the ends of the f64 range get here; a scene of ordinary
                // numbers that diverges would be a simulator bug.
                assert!(
                    extreme || scale >= 1e6,
                    "{msg} with ordinary values (controls ×{scale})\n{text}"
                );
                outcome.diverged += 1;
            }
            Err(e) => panic!("unexpected error for finite controls: {e}\n{text}"),
        }
    }
    outcome
}

/// The names of the built-in scenes on a grid cloth (the fuzzing mutates grid fields and
/// refines them).
fn grid_builtins() -> impl Iterator<Item = &'static str> {
    Scene::builtin_names()
        .iter()
        .map(|(name, _)| *name)
        .filter(|name| !Scene::builtin(name).unwrap().cloth.is_mesh())
}

/// The grid built-in scenes' JSON.
fn builtins() -> Vec<Value> {
    grid_builtins()
        .map(|name| {
            let text = Scene::builtin(name).unwrap().to_json_pretty();
            serde_json::from_str(&text).unwrap()
        })
        .collect()
}

/// A small version of each built-in scene (4×4, T = 3, 10 iterations), so that most mutated
/// scenes are small enough to simulate.
fn small_builtins() -> Vec<Value> {
    grid_builtins()
        .map(|name| {
            let mut s = Scene::builtin(name).unwrap().refined(4, 4).unwrap();
            s.physics.iterations = 10;
            s.task.horizon = 3;
            s.task.initial_controls = cloth::scene::InitialControls::Zeros;
            serde_json::from_str(&s.to_json_pretty()).unwrap()
        })
        .collect()
}

fn mutation() -> impl Strategy<Value = (u8, u64, u64)> {
    (any::<u8>(), any::<u64>(), any::<u64>())
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 600, ..ProptestConfig::default() })]

    /// Value-level mutations of the (small and full-size) built-in scenes.
    #[test]
    fn mutated_scenes_never_panic_and_simulate_without_nan(
        base in 0usize..6,
        mutations in prop::collection::vec(mutation(), 1..5),
        text_mutation in (0u8..6, any::<u64>(), any::<u64>()),
        control_seed in any::<u64>(),
    ) {
        let mut v = if base < 3 { small_builtins() } else { builtins() }.swap_remove(base % 3);
        for (kind, a, b) in mutations {
            mutate(&mut v, kind, a, b);
        }
        let text = serde_json::to_string_pretty(&v).unwrap();
        let (tk, ta, tb) = text_mutation;
        // One input in three also gets a text-level mutation.
        let text = if tk < 2 { mutate_text(&text, tk, ta, tb) } else { text };
        check(&text, control_seed);
    }

    /// Arbitrary text: never panics.
    #[test]
    fn arbitrary_text_never_panics(text in ".{0,200}") {
        check(&text, 0);
    }
}

/// The unmutated built-ins and their small versions pass the same checks (so the property is not
/// vacuous), and a fixed sample of mutations exercises every branch: some inputs are accepted
/// and simulated, some rejected.
#[test]
fn the_checks_accept_valid_scenes_and_the_mutations_reach_the_simulator() {
    for v in builtins().into_iter().chain(small_builtins()) {
        let text = serde_json::to_string_pretty(&v).unwrap();
        let o = check(&text, 1);
        assert!(!o.rejected, "{text}");
    }
    let (mut accepted, mut rejected, mut simulated) = (0, 0, 0);
    let mut rng = noise(99, 3000).into_iter().map(|x| (x.abs() * 1e15) as u64);
    let mut next = move || rng.next().unwrap();
    for case in 0..300u64 {
        let mut v = small_builtins().swap_remove((case % 3) as usize);
        for _ in 0..1 + case % 3 {
            mutate(&mut v, next() as u8, next(), next());
        }
        let o = check(&serde_json::to_string_pretty(&v).unwrap(), case);
        if o.rejected {
            rejected += 1;
        } else {
            accepted += 1;
        }
        simulated += o.finite_rollouts + o.diverged;
    }
    println!("300 mutated scenes: {accepted} accepted, {rejected} rejected, {simulated} rollouts");
    assert!(accepted >= 30 && rejected >= 30, "{accepted} / {rejected}");
    assert!(simulated >= 30, "{simulated}");
}
