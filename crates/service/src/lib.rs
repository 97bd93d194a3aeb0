//! abba-service (being built).
