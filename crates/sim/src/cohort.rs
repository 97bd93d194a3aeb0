//! Virtual cohorts (being built).
