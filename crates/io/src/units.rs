//! Glucose units (never guessed) and the plausibility limits of every value.

use crate::error::{IoError, Location};

/// Tidepool's own mg/dL per mmol/L (its data model stores mmol/L and
/// converts with this factor).
pub const TIDEPOOL_MG_DL_PER_MMOL_L: f64 = 18.01559;

/// How far (mg/dL) a glucose value Tidepool gives can be from the whole
/// mg/dL the device read: Tidepool keeps glucose in mmol/L to 5 decimals,
/// so a reading of 100 mg/dL is kept as 5.55075 and comes back as
/// 100.00004 (half the last decimal, times the factor; a hair more for
/// the floating point).
const TIDEPOOL_ROUNDING_MG_DL: f64 = 0.5e-5 * TIDEPOOL_MG_DL_PER_MMOL_L * (1.0 + 1e-9);

/// A Tidepool glucose value in mg/dL (converted from its mmol/L, or as
/// its export in mg/dL writes it): the whole mg/dL the device read when
/// the value is within Tidepool's rounding of one (5.55075 mmol/L is 100
/// mg/dL, not 100.00004, which would count a reading at 54 or 180 mg/dL
/// on the wrong side of a threshold); any other value as it is (a meter's
/// 5.6 mmol/L is 100.887 mg/dL).
pub fn tidepool_mg_dl(mg: f64) -> f64 {
    let whole = mg.round();
    if (mg - whole).abs() <= TIDEPOOL_ROUNDING_MG_DL {
        whole
    } else {
        mg
    }
}

/// Glucose below this is not a reading (mg/dL); the advisor's limit too.
pub const GLUCOSE_MIN_MG_DL: f64 = 10.0;
/// Glucose above this is not a reading (mg/dL); the advisor's limit too.
pub const GLUCOSE_MAX_MG_DL: f64 = 1000.0;
/// Largest plausible single bolus (U).
pub const BOLUS_MAX_U: f64 = 50.0;
/// Largest plausible carbohydrate entry (g).
pub const CARBS_MAX_G: f64 = 500.0;
/// Largest plausible basal rate (U/h).
pub const BASAL_MAX_U_PER_H: f64 = 50.0;
/// Longest plausible temporary basal, extended bolus or suspension (min).
pub const DURATION_MAX_MIN: f64 = 1440.0;
/// Smallest plausible carb ratio (g/U).
pub const CARB_RATIO_MIN_G_PER_U: f64 = 1.0;
/// Largest plausible carb ratio (g/U).
pub const CARB_RATIO_MAX_G_PER_U: f64 = 150.0;
/// Largest plausible temporary-basal percentage.
pub const PERCENT_MAX: f64 = 250.0;

pub use abba_core::units::GlucoseUnit;

/// Checks a finite number against `[min, max]`, naming the field.
pub fn check_range(
    at: &Location,
    field: &str,
    value: f64,
    min: f64,
    max: f64,
    what: &str,
) -> Result<f64, IoError> {
    if !abba_core::limits::within(value, min, max) {
        return Err(IoError::invalid(
            at.clone(),
            field,
            format!("{what} {value} is outside the plausible range {min}..{max}"),
        ));
    }
    Ok(value)
}

/// Checks a glucose value given in `unit` and returns it in mg/dL. A value
/// outside the limits says which unit it would fit.
pub fn glucose_mg_dl(
    at: &Location,
    field: &str,
    value: f64,
    unit: GlucoseUnit,
) -> Result<f64, IoError> {
    let mg = unit.to_mg_dl(value);
    if abba_core::limits::within(mg, GLUCOSE_MIN_MG_DL, GLUCOSE_MAX_MG_DL) {
        return Ok(mg);
    }
    let hint = match unit {
        GlucoseUnit::MgDl if (0.5..GLUCOSE_MIN_MG_DL).contains(&value) => {
            "; it looks like mmol/L (check --units or the file's unit)"
        }
        GlucoseUnit::MmolL
            if (GLUCOSE_MIN_MG_DL..=GLUCOSE_MAX_MG_DL).contains(&value) && value > 35.0 =>
        {
            "; it looks like mg/dL (check --units or the file's unit)"
        }
        _ => "",
    };
    Err(IoError::invalid(
        at.clone(),
        field,
        format!(
            "glucose {value} {} is outside the plausible range {GLUCOSE_MIN_MG_DL}..{GLUCOSE_MAX_MG_DL} mg/dL{hint}",
            unit.label()
        ),
    ))
}

/// The whole-file check for data whose unit came from `--units`: a median
/// below 25 read as mg/dL, or above 35 read as mmol/L, is an error that
/// says which unit the data looks like. `values` are the raw numbers as
/// written.
pub fn check_median(file: &str, values: &[f64], unit: GlucoseUnit) -> Result<(), IoError> {
    if values.is_empty() {
        return Ok(());
    }
    let mut v = values.to_vec();
    v.sort_by(f64::total_cmp);
    let median = v[v.len() / 2];
    let wrong = match unit {
        GlucoseUnit::MgDl => median < 25.0,
        GlucoseUnit::MmolL => median > 35.0,
    };
    if wrong {
        let looks = match unit {
            GlucoseUnit::MgDl => GlucoseUnit::MmolL,
            GlucoseUnit::MmolL => GlucoseUnit::MgDl,
        };
        return Err(IoError::Units {
            file: file.to_string(),
            message: format!(
                "the glucose values were read as {} but their median is {median}, which looks \
                 like {}; check --units",
                unit.label(),
                looks.label()
            ),
        });
    }
    Ok(())
}
