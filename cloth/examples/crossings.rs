//! Does the cloth pass through itself? The fold under XPBD (`fold_xpbd.json`) from its arc,
//! simulated without self-collision, with vertex–triangle contacts (the scene as shipped) and with edge–edge
//! contacts too (`physics.self_collision.edge_edge`): per step, the edge–edge and vertex–triangle
//! crossings between consecutive states (`cloth::crossings`) and the edge–triangle
//! intersections of each state, the contact pairs, and the simulation's wall time.
//!
//! `cargo run --release -p cloth --example crossings`

use cloth::{crossings, intersections};
use cloth::{Model, Scene};
use std::time::Instant;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let shipped = Scene::load(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../examples/scenes/fold/fold_xpbd.json"
    ))?;
    let mut none = shipped.clone();
    none.physics.self_collision = None;
    let mut edges = shipped.clone();
    if let Some(sc) = edges.physics.self_collision.as_mut() {
        sc.edge_edge = true;
    }
    let u = shipped.initial_controls();
    for (name, scene) in [
        ("no self-collision", none),
        ("vertex–triangle (shipped)", shipped),
        ("vertex–triangle + edge–edge", edges),
    ] {
        let model = Model::from_scene(&scene)?;
        let start = Instant::now();
        let states = model.simulate(&u)?;
        let wall = start.elapsed().as_secs_f64();
        let (mut ee, mut vt, mut cut, mut pairs) = (vec![], vec![], vec![], vec![]);
        for t in 1..states.len() {
            let c = crossings(&model.triangles, &states[t - 1], &states[t]);
            ee.push(c.edge_edge.len());
            vt.push(c.vertex_triangle.len());
            cut.push(intersections(&model.triangles, &states[t]).len());
            let ut = model.step_controls(&u, t - 1);
            let held = model.contact_pairs(&states[t - 1], &ut);
            pairs.push((
                held.len(),
                model.edge_pairs(&states[t - 1], &ut, &held).len(),
            ));
        }
        let sum = |v: &[usize]| v.iter().sum::<usize>();
        println!("{name}: simulate {wall:.3} s");
        println!(
            "  edge–edge crossings per step     {ee:?} (total {})",
            sum(&ee)
        );
        println!(
            "  vertex–triangle crossings         {vt:?} (total {})",
            sum(&vt)
        );
        println!("  intersections at each state      {cut:?}");
        println!("  (vertex–triangle, edge–edge) pairs {pairs:?}");
    }
    Ok(())
}
