//! Devices: CGM, SMBG meter, insulin pump (being built).
