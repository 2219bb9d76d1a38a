//! Contact effects beyond the plain one-sided collider constraint.

pub mod friction;
