//! clothopt
