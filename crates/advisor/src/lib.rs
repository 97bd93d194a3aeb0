//! The ABBA adaptive basal-bolus advisor and its baselines.
