//! The population prior and the identified parameters.
//!
//! The twin starts from the *typical* patient of the person's population:
//! every primary parameter of the cohort generator ([`derive::PRIMARY`]) at
//! the mean of its logarithm over the group's ten public patients, the
//! common ones ([`derive::COMMON`]) at their shared value, and the steady
//! state derived as the generator derives it. This is the centre of the
//! cohort generator's distribution (a log-space mix of two public patients
//! plus N(0, 0.1²) noise).
//!
//! Eight parameters are identified, as log multipliers with a normal prior:
//!
//! | name | multiplies | prior | why identifiable from CGM, insulin, carbs |
//! |---|---|---|---|
//! | `insulin_sensitivity` | Vmx and kp3 | SD of ln Vmx over the public group ⊕ 0.1 | the fall after each bolus |
//! | `basal_need` | Ib (so the basal rate u2ss that holds Gb) | centred on the person's scheduled basal, SD 0.15 (see below) | the night-time drift under the delivered basal |
//! | `basal_glucose` | Gb | SD of ln Gb ⊕ 0.1 | the level glucose settles to overnight |
//! | `absorption` | kabs | SD of ln kabs ⊕ 0.1 | the time to the meal peak |
//! | `carb_factor_{breakfast,lunch,dinner}` | the logged grams of that meal | 1, SD 0.3 | the size of each meal's rise against its bolus |
//! | `dawn_factor` | insulin sensitivity from 04:00 to 08:00 (30-minute ramps) | 1, SD 0.4 | the early-morning rise under a steady basal |
//!
//! The basal need is the parameter the data inform least: with the basal
//! held flat, a higher need and a lower basal glucose give similar nights,
//! and only a change of basal tells them apart. So its prior is the
//! scheduled basal (titrated to hold fasting glucose) with 15 % spread.
//! Even so, on simulated persons whose schedule is their exact need the
//! fit settles 15-35 % above it (the daily sensitivity factors and the
//! dawn effect read as a higher need): the main error of basal what-ifs
//! (BENCHMARKS.md, "The twin").
//!
//! Not identified (population values): body weight (insulin and
//! carbohydrate act per kg; its effect is absorbed by the sensitivity, the
//! basal need and the carb factors), the gastric-emptying shape (kmax, kmin,
//! b, d), the bioavailability f (confounded with the carb factors, which
//! carry it), the insulin kinetics (ka1, ka2, kd, m1..m4: one subcutaneous
//! insulin signal cannot separate them from the sensitivity), renal
//! excretion and the sensor delay ksc. Day-to-day changes of sensitivity
//! (illness, exercise, the simulated persons' daily factor of 0.75-1.25)
//! are not modelled: they stay in the residual and in the bands.

use crate::error::TwinError;
use abba_sim::cohort::{derive, Population};
use abba_sim::patient::PatientParams;
use serde::{Deserialize, Serialize};

/// The identified parameters, in the order of the parameter vector.
pub const NAMES: [&str; 8] = [
    "insulin_sensitivity",
    "basal_need",
    "basal_glucose",
    "absorption",
    "carb_factor_breakfast",
    "carb_factor_lunch",
    "carb_factor_dinner",
    "dawn_factor",
];

/// Number of identified parameters.
pub const N_PARAMS: usize = NAMES.len();

/// Prior SD of the log basal need around the person's scheduled basal.
const BASAL_NEED_SD: f64 = 0.15;
/// Prior SD of a log carb factor.
const CARB_FACTOR_SD: f64 = 0.3;
/// Prior SD of the log dawn factor.
const DAWN_SD: f64 = 0.4;
/// The cohort generator's log-space noise.
const MIX_NOISE_SD: f64 = 0.1;

/// The identified factors that act outside the model's parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Extras {
    /// Factor on the logged grams of breakfast, lunch and dinner.
    pub carb_factors: [f64; 3],
    /// Insulin sensitivity from 04:00 to 08:00 ([`crate::sim::dawn`]).
    pub dawn_factor: f64,
}

/// The prior: the typical patient of a population and, per identified
/// parameter, the mean and SD of its log multiplier.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Prior {
    /// The population.
    pub population: Population,
    /// The typical patient (the multipliers apply to it).
    pub base: PatientParams,
    /// Prior mean of each log multiplier.
    pub mean: [f64; N_PARAMS],
    /// Prior SD of each log multiplier.
    pub sd: [f64; N_PARAMS],
}

fn log_sd(values: &[f64]) -> f64 {
    let n = values.len() as f64;
    let logs: Vec<f64> = values.iter().map(|v| v.ln()).collect();
    let m = logs.iter().sum::<f64>() / n;
    (logs.iter().map(|l| (l - m).powi(2)).sum::<f64>() / (n - 1.0)).sqrt()
}

impl Prior {
    /// The prior of `population` for a person whose scheduled basal rate
    /// averages `scheduled_basal_u_per_h` over the window.
    pub fn new(population: Population, scheduled_basal_u_per_h: f64) -> Result<Prior, TwinError> {
        let prefix = format!("{}#", population.prefix());
        let public: Vec<PatientParams> = PatientParams::all_public()?
            .into_iter()
            .filter(|p| p.name.starts_with(&prefix))
            .collect();
        let Some(first) = public.first() else {
            return Err(TwinError::Data(format!(
                "no public patients of population {population}"
            )));
        };
        let mut base = first.clone();
        base.name = format!("twin of a typical {}", population.prefix());
        base.i = 0;
        let mut column = |col: &str| -> Result<Vec<f64>, TwinError> {
            public
                .iter()
                .map(|p| {
                    p.scalar(col)
                        .ok_or_else(|| TwinError::Data(format!("{col} is not a patient parameter")))
                })
                .collect()
        };
        for col in derive::PRIMARY {
            let v = column(col)?;
            let mean_log = v.iter().map(|x| x.ln()).sum::<f64>() / v.len() as f64;
            if let Some(slot) = base.scalar_mut(col) {
                *slot = mean_log.exp();
            }
        }
        derive::derive_steady_state(&mut base)?;
        base.validate()?;
        let spread = |col: &str, column: &mut dyn FnMut(&str) -> Result<Vec<f64>, TwinError>| {
            column(col).map(|v| log_sd(&v).hypot(MIX_NOISE_SD))
        };
        let sd = [
            spread("Vmx", &mut column)?,
            BASAL_NEED_SD,
            spread("Gb", &mut column)?,
            spread("kabs", &mut column)?,
            CARB_FACTOR_SD,
            CARB_FACTOR_SD,
            CARB_FACTOR_SD,
            DAWN_SD,
        ];
        if !(scheduled_basal_u_per_h.is_finite() && scheduled_basal_u_per_h > 0.0) {
            return Err(TwinError::Data(format!(
                "the scheduled basal rate averages {scheduled_basal_u_per_h} U/h over the window: \
                 a twin needs the pump's basal rate (a BasalRate record or profile)"
            )));
        }
        let base_basal = base.basal_u_per_min() * 60.0;
        let mut mean = [0.0; N_PARAMS];
        mean[1] = (scheduled_basal_u_per_h / base_basal).ln();
        Ok(Prior {
            population,
            base,
            mean,
            sd,
        })
    }

    /// Log multipliers from standardised coordinates z (0 = the prior mean).
    pub fn log_multipliers(&self, z: &[f64]) -> [f64; N_PARAMS] {
        std::array::from_fn(|k| self.mean[k] + self.sd[k] * z[k])
    }

    /// The model parameters at z, with a derived steady state, and the
    /// factors that act outside them (on the logged grams, on the
    /// sensitivity at dawn).
    pub fn params(&self, z: &[f64]) -> Result<(PatientParams, Extras), TwinError> {
        let m = self.log_multipliers(z).map(f64::exp);
        let mut p = self.base.clone();
        p.vmx *= m[0];
        p.kp3 *= m[0];
        p.ib *= m[1];
        p.gb *= m[2];
        p.kabs *= m[3];
        derive::derive_steady_state(&mut p)?;
        p.validate()?;
        Ok((
            p,
            Extras {
                carb_factors: [m[4], m[5], m[6]],
                dawn_factor: m[7],
            },
        ))
    }

    /// The identified values in natural units at z: the multipliers, and
    /// for the basal need the basal rate (U/h) that holds basal glucose.
    pub fn values(&self, z: &[f64]) -> [f64; N_PARAMS] {
        let m = self.log_multipliers(z).map(f64::exp);
        let mut v = m;
        v[1] = self.base.basal_u_per_min() * 60.0 * m[1];
        v[2] = self.base.gb * m[2];
        v[3] = self.base.kabs * m[3];
        v
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_typical_patient_is_steady_and_the_basal_need_is_centred_on_the_schedule() {
        for pop in Population::ALL {
            let prior = Prior::new(pop, 0.8).unwrap();
            let r = derive::steady_state_residual(&prior.base);
            assert!(r.iter().all(|v| v.abs() < 1e-9), "{pop}: {r:?}");
            let (p, f) = prior.params(&[0.0; N_PARAMS]).unwrap();
            assert!((p.basal_u_per_min() * 60.0 - 0.8).abs() < 1e-9, "{pop}");
            assert_eq!(f.carb_factors, [1.0; 3]);
            assert_eq!(f.dawn_factor, 1.0);
            assert!(
                prior.sd.iter().all(|s| *s > 0.05 && *s < 1.5),
                "{:?}",
                prior.sd
            );
        }
        let e = Prior::new(Population::Adults, 0.0).unwrap_err().to_string();
        assert!(e.contains("scheduled basal"), "{e}");
    }
}
