//! The UVA/Padova 2008 patient model (being built).
