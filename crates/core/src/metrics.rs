//! Glucose metrics (iglu's definitions). Filled in by the metrics work.
