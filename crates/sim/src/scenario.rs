//! Scenario generation: meals, insulin sensitivity, SMBG schedule (being built).
