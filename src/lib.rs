//! clothopt

pub mod plot;
