//! How much data a window needs before ABBA updates from it. The paper's
//! algorithm updates from any non-empty window; a person's real days have
//! sensor gaps and forgotten meter readings, so the person store asks for a
//! minimum (the trial sets none and is unchanged).

use crate::config::Mode;
use crate::features::WindowStats;
use abba_core::Timestamp;
use serde::{Deserialize, Serialize};

/// Minimum data per window.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct MinData {
    /// CGM mode: the share of the window's expected readings (one per
    /// `cgm_period_min`) that must be present, in [0, 1].
    pub cgm_coverage: f64,
    /// CGM mode: minutes between readings of the sensor.
    pub cgm_period_min: u32,
    /// SMBG mode: meter readings a day needs for a basal update.
    pub smbg_per_day: u32,
    /// SMBG mode: meter readings a meal window needs for a carb-ratio update.
    pub smbg_per_meal: u32,
}

impl Default for MinData {
    /// 70 % of a 5-minute CGM, 3 meter readings a day, 1 per meal window.
    fn default() -> Self {
        Self {
            cgm_coverage: 0.7,
            cgm_period_min: 5,
            smbg_per_day: 3,
            smbg_per_meal: 1,
        }
    }
}

impl MinData {
    /// Readings a window `[start, end)` needs (`day` tells a day window from
    /// a meal window in SMBG mode).
    pub fn required(&self, mode: Mode, start: Timestamp, end: Timestamp, day: bool) -> u32 {
        match mode {
            Mode::Cgm => {
                let minutes = (end.0 - start.0).max(0) as f64;
                let expected = minutes / f64::from(self.cgm_period_min.max(1));
                (self.cgm_coverage.clamp(0.0, 1.0) * expected).floor() as u32
            }
            Mode::Smbg if day => self.smbg_per_day,
            Mode::Smbg => self.smbg_per_meal,
        }
    }

    /// True when `stats` holds enough readings.
    pub fn enough(
        &self,
        mode: Mode,
        start: Timestamp,
        end: Timestamp,
        day: bool,
        stats: &WindowStats,
    ) -> bool {
        stats.n >= self.required(mode, start, end, day)
    }
}
