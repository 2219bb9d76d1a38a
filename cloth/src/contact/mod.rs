//! Contacts whose constraints are found during the simulation rather than fixed at model build.

pub mod self_collision;
