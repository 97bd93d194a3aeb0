//! UVA/Padova 2008 type 1 diabetes simulator: the patient model and its
//! solver, virtual cohorts, CGM, SMBG meter and pump, and scenario generation.
