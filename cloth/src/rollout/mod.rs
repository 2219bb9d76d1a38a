//! A rollout's costs and their derivatives with respect to the controls.
//!
//! - [`cost`]: the paper's costs (`G`, `E`, the safety term, `T`) recorded on a tape;
//! - [`strain`]: edge strain and its smooth maximum (the `max_strain` rows);
//! - [`held_clearance`]: the held particles' gaps to the rest of the cloth under smooth
//!   self-contact, and their smooth minimum (the planner's held-clearance rows);
//! - [`swept`]: the safety field along each particle's straight motion between two states (the
//!   continuous safety rows);
//! - [`tapes`]: recording tapes kept between evaluations;
//! - [`penetration`]: how deep the particles go into the colliders;
//! - [`limits`]: what a counted rollout may spend (Newton iterations, a deadline);
//! - [`checkpoints`]: block checkpoints the plain forward keeps for the backward pass;
//! - [`metrics`]: what an evaluation returns (`Metrics`, `Evaluation`);
//! - [`grad`]: metrics of a rollout, and gradients of any per-step costs by reverse mode
//!   (checkpointed per step or per block of iterations).

pub mod checkpoints;
pub mod cost;
pub mod coverage;
pub mod grad;
pub mod held_clearance;
pub mod layers;
pub mod limits;
pub mod metrics;
pub mod penetration;
pub mod strain;
pub mod swept;
pub mod tapes;
