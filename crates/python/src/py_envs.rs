//! The environment cores the Python gymnasium classes wrap: one
//! environment, or a batch stepped in one call.

use crate::daily_env::{DailySim, DayOut};
use crate::minute_env::{CompatPump, Meals, MinuteEnvConfig, MinuteShard, MinuteSim};
use crate::py_sim::{cohort_patient, params_of};
use crate::value_error;
use abba_sim::devices::cgm::CgmConfig;
use abba_sim::scenario::{ScenarioConfig, ScenarioId};
use numpy::{IntoPyArray, PyArray1, PyArray2, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::prelude::*;
use pyo3::types::PyDict;

pub(crate) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<MinuteCore>()?;
    m.add_class::<MinuteBatch>()?;
    m.add_class::<DailyCore>()?;
    m.add_class::<DailyBatch>()?;
    Ok(())
}

/// simglucose's pumps (`pump_params.csv`): basal increment 0.05 pmol/min,
/// largest rate 30 U/min (Insulet) or 35 U/min (Cozmo).
fn compat_pump(name: &str) -> PyResult<CompatPump> {
    let max = match name {
        "Insulet" => 30.0,
        "Cozmo" => 35.0,
        _ => {
            return Err(value_error(format!(
                "pump '{name}': expected Insulet or Cozmo (simglucose's pumps)"
            )))
        }
    };
    Ok(CompatPump {
        inc_pmol_per_min: 0.05,
        max_u_per_min: max,
    })
}

#[allow(clippy::too_many_arguments)]
fn minute_config(
    patient: &str,
    sensor: &str,
    pump: &str,
    meals: Option<Vec<(i64, f64)>>,
    random_init_bg: bool,
    init_state: Option<Vec<f64>>,
    start_minute_of_day: Option<u32>,
    cohort_seed: u64,
) -> PyResult<MinuteEnvConfig> {
    let init_state = match init_state {
        None => None,
        Some(v) => Some(<[f64; 13]>::try_from(v.as_slice()).map_err(|_| {
            value_error(format!(
                "init_state: expected 13 values (x1..x13), got {}",
                v.len()
            ))
        })?),
    };
    if let Some(list) = &meals {
        if let Some((m, g)) = list
            .iter()
            .find(|(m, g)| *m < 0 || !(g.is_finite() && *g >= 0.0))
        {
            return Err(value_error(format!(
                "meals: ({m} min, {g} g): expected minutes >= 0 and finite grams >= 0"
            )));
        }
    }
    Ok(MinuteEnvConfig {
        params: params_of(patient, cohort_seed)?,
        cgm: CgmConfig::from_table(sensor).map_err(value_error)?,
        pump: compat_pump(pump)?,
        meals: meals.map_or(Meals::Random, Meals::Custom),
        random_init_bg,
        init_state,
        start_minute_of_day,
    })
}

/// One minute-level environment.
#[pyclass(module = "abba._abba")]
pub struct MinuteCore {
    sim: MinuteSim,
}

#[pymethods]
impl MinuteCore {
    /// See `abba.envs.T1DSimEnv`.
    #[new]
    #[pyo3(signature = (patient, sensor = "Dexcom", pump = "Insulet", meals = None, random_init_bg = true, init_state = None, start_minute_of_day = None, cohort_seed = 1, seed = 0))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        patient: &str,
        sensor: &str,
        pump: &str,
        meals: Option<Vec<(i64, f64)>>,
        random_init_bg: bool,
        init_state: Option<Vec<f64>>,
        start_minute_of_day: Option<u32>,
        cohort_seed: u64,
        seed: u64,
    ) -> PyResult<Self> {
        let config = minute_config(
            patient,
            sensor,
            pump,
            meals,
            random_init_bg,
            init_state,
            start_minute_of_day,
            cohort_seed,
        )?;
        Ok(Self {
            sim: MinuteSim::new(config, seed).map_err(value_error)?,
        })
    }

    /// New episode; returns the first CGM reading (mg/dL).
    fn reset(&mut self, seed: u64) -> PyResult<f64> {
        self.sim.reset(seed).map_err(value_error)
    }

    /// One step; returns (cgm, bg, plasma, meal_g_per_min, cho_g_per_min,
    /// insulin_u_per_min, done).
    #[allow(clippy::type_complexity)]
    fn step(
        &mut self,
        basal_u_per_min: f64,
        bolus_u_per_min: f64,
    ) -> PyResult<(f64, f64, f64, f64, f64, f64, bool)> {
        let o = self
            .sim
            .step(basal_u_per_min, bolus_u_per_min)
            .map_err(value_error)?;
        Ok((
            o.cgm_mg_dl,
            o.bg_mg_dl,
            o.plasma_mg_dl,
            o.meal_g_per_min,
            o.cho_g_per_min,
            o.insulin_u_per_min,
            o.done,
        ))
    }

    /// Minutes since the episode started.
    #[getter]
    fn minute(&self) -> i64 {
        self.sim.minute()
    }

    /// Time of day (minutes after midnight).
    #[getter]
    fn minute_of_day(&self) -> u32 {
        self.sim.minute_of_day()
    }

    /// Minutes per step (the CGM's sample time).
    #[getter]
    fn sample_time_min(&self) -> u32 {
        self.sim.sample_time_min()
    }

    /// Largest basal rate of the pump (U/min).
    #[getter]
    fn max_basal_u_per_min(&self) -> f64 {
        self.sim.config().pump.max_u_per_min
    }

    /// The patient's name.
    #[getter]
    fn patient_name(&self) -> String {
        self.sim.patient().params().name.clone()
    }

    /// Subcutaneous glucose now (mg/dL).
    #[getter]
    fn bg_mg_dl(&self) -> f64 {
        self.sim.patient().subcutaneous_glucose_mg_dl()
    }

    /// Plasma glucose now (mg/dL).
    #[getter]
    fn plasma_mg_dl(&self) -> f64 {
        self.sim.patient().glucose_mg_dl()
    }

    /// The model state x1..x13 now.
    #[getter]
    fn state(&self) -> Vec<f64> {
        self.sim.patient().state_array().to_vec()
    }
}

/// Many minute-level environments stepped in one call.
#[pyclass(module = "abba._abba")]
pub struct MinuteBatch {
    /// The environments in order, in shards of `shard_len` (the last may
    /// be shorter): one shard per core, each a `PatientBatch`.
    shards: Vec<MinuteShard>,
    shard_len: usize,
    sample_time_min: u32,
    /// Steps since each environment's reset (for truncation).
    steps: Vec<u64>,
    /// The risk of each environment's last CGM reading (for the reward).
    last_risk: Vec<f64>,
}

type Arr<'py> = Bound<'py, PyArray1<f64>>;

/// A batch needs one seed per patient, and at least one patient.
fn check_batch(patients: &[String], seeds: &[u64]) -> PyResult<()> {
    if patients.len() != seeds.len() || patients.is_empty() {
        return Err(value_error(format!(
            "{} patients and {} seeds: expected the same number, at least 1",
            patients.len(),
            seeds.len()
        )));
    }
    Ok(())
}

/// Shards of a batch of `n` environments: one per core while each holds
/// at least 256 environments (measured on 2 cores: 256 environments step
/// faster on one thread than on two, 4.0 against 5.0 M steps/s of the core
/// but 3.1 against 2.8 of the Python environment, whose calls leave
/// rayon's workers asleep; 1,024 gain from two). A patient's results do
/// not depend on its shard, so the number of cores does not change them.
fn shard_len(n: usize) -> usize {
    let per_shard = 256;
    let shards = rayon::current_num_threads().min(n / per_shard).max(1);
    n.div_ceil(shards)
}

#[pymethods]
impl MinuteBatch {
    /// `patients[i]` is environment i's patient; seeds[i] its first seed.
    #[new]
    #[pyo3(signature = (patients, seeds, sensor = "Dexcom", pump = "Insulet", meals = None, random_init_bg = true, start_minute_of_day = None, cohort_seed = 1))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        patients: Vec<String>,
        seeds: Vec<u64>,
        sensor: &str,
        pump: &str,
        meals: Option<Vec<(i64, f64)>>,
        random_init_bg: bool,
        start_minute_of_day: Option<u32>,
        cohort_seed: u64,
    ) -> PyResult<Self> {
        check_batch(&patients, &seeds)?;
        let configs = patients
            .iter()
            .map(|p| {
                minute_config(
                    p,
                    sensor,
                    pump,
                    meals.clone(),
                    random_init_bg,
                    None,
                    start_minute_of_day,
                    cohort_seed,
                )
            })
            .collect::<PyResult<Vec<_>>>()?;
        let sample_time_min = configs[0].cgm.sample_time_min;
        let len = shard_len(configs.len());
        let mut shards = Vec::new();
        let mut last_risk = Vec::with_capacity(seeds.len());
        let mut rest = configs;
        for seeds in seeds.chunks(len) {
            let tail = rest.split_off(seeds.len());
            let (shard, first) = MinuteShard::new(rest, seeds).map_err(value_error)?;
            shards.push(shard);
            last_risk.extend(first.into_iter().map(risk));
            rest = tail;
        }
        Ok(Self {
            shards,
            shard_len: len,
            sample_time_min,
            steps: vec![0; last_risk.len()],
            last_risk,
        })
    }

    /// Resets environment `i`; returns its first CGM reading.
    fn reset_one(&mut self, i: usize, seed: u64) -> PyResult<f64> {
        let n = self.__len__();
        if i >= n {
            return Err(value_error(format!("environment {i} of {n}")));
        }
        let first = self.shards[i / self.shard_len]
            .reset_one(i % self.shard_len, seed)
            .map_err(value_error)?;
        self.steps[i] = 0;
        self.last_risk[i] = risk(first);
        Ok(first)
    }

    /// One step of every environment: basal and bolus rates (U/min), one
    /// per environment. Returns arrays (cgm, bg, plasma, meal_g_per_min,
    /// cho_g_per_min, insulin_u_per_min, done as 0/1, the risk of the CGM
    /// value as simglucose's `risk_index`: its default reward's term).
    #[allow(clippy::type_complexity)]
    fn step<'py>(
        &mut self,
        py: Python<'py>,
        basal_u_per_min: PyReadonlyArray1<'py, f64>,
        bolus_u_per_min: PyReadonlyArray1<'py, f64>,
    ) -> PyResult<(
        Arr<'py>,
        Arr<'py>,
        Arr<'py>,
        Arr<'py>,
        Arr<'py>,
        Arr<'py>,
        Arr<'py>,
        Arr<'py>,
    )> {
        let basal = basal_u_per_min.as_slice().map_err(value_error)?;
        let bolus = bolus_u_per_min.as_slice().map_err(value_error)?;
        let outs = self.step_all(py, basal, bolus)?;
        let n = outs.len();
        let mut cols: [Vec<f64>; 8] = std::array::from_fn(|_| Vec::with_capacity(n));
        for o in outs {
            let [a, b, c, d, e, f] = o.columns();
            let row = [
                a,
                b,
                c,
                d,
                e,
                f,
                f64::from(u8::from(o.done)),
                risk(o.cgm_mg_dl),
            ];
            for (c, v) in cols.iter_mut().zip(row) {
                c.push(v);
            }
        }
        let [a, b, c, d, e, f, g, h] = cols;
        Ok((
            a.into_pyarray(py),
            b.into_pyarray(py),
            c.into_pyarray(py),
            d.into_pyarray(py),
            e.into_pyarray(py),
            f.into_pyarray(py),
            g.into_pyarray(py),
            h.into_pyarray(py),
        ))
    }

    /// One step of every environment as `T1DSimVectorEnv.step` returns it,
    /// the episode bookkeeping done here (a numpy call costs about a
    /// microsecond, as much as 10 environments' minutes): `actions` of
    /// shape (n, 1) or (n, 2) (basal, and bolus when `bolus_action`),
    /// U/min. Returns (observation as float32 of shape (n, 1), reward:
    /// simglucose's `risk_diff`, zero when `risk_reward` is false,
    /// terminated, truncated after `max_episode_steps`, the indices of the
    /// environments that ended (None: none did), the CGM readings as
    /// float64 (None unless `want_cgm`), and the arrays bg, plasma,
    /// meal_g_per_min, cho_g_per_min, insulin_u_per_min).
    #[pyo3(signature = (actions, bolus_action, max_episode_steps, risk_reward = true, want_cgm = false))]
    #[allow(clippy::type_complexity)]
    fn step_gym<'py>(
        &mut self,
        py: Python<'py>,
        actions: PyReadonlyArray2<'py, f64>,
        bolus_action: bool,
        max_episode_steps: Option<u64>,
        risk_reward: bool,
        want_cgm: bool,
    ) -> PyResult<(
        Bound<'py, PyArray2<f32>>,
        Arr<'py>,
        Bound<'py, PyArray1<bool>>,
        Bound<'py, PyArray1<bool>>,
        Option<Vec<usize>>,
        Option<Arr<'py>>,
        Arr<'py>,
        Arr<'py>,
        Arr<'py>,
        Arr<'py>,
        Arr<'py>,
    )> {
        let n = self.__len__();
        let a = actions.as_array();
        let width = a.ncols();
        if a.nrows() != n || width == 0 || (bolus_action && width < 2) {
            return Err(value_error(format!(
                "expected actions of shape ({n}, {}), got {:?}",
                if bolus_action { 2 } else { 1 },
                a.shape()
            )));
        }
        let basal: Vec<f64> = a.column(0).to_vec();
        let bolus: Vec<f64> = if bolus_action {
            a.column(1).to_vec()
        } else {
            vec![0.0; n]
        };
        let outs = self.step_all(py, &basal, &bolus)?;
        let mut obs = Vec::with_capacity(n);
        let mut reward = Vec::with_capacity(n);
        let mut terminated = Vec::with_capacity(n);
        let mut truncated = Vec::with_capacity(n);
        let mut ended = Vec::new();
        let mut cols: [Vec<f64>; 6] = std::array::from_fn(|_| Vec::with_capacity(n));
        for (i, o) in outs.into_iter().enumerate() {
            self.steps[i] += 1;
            let r = risk(o.cgm_mg_dl);
            reward.push(if risk_reward {
                self.last_risk[i] - r
            } else {
                0.0
            });
            self.last_risk[i] = r;
            let cut = !o.done && max_episode_steps.is_some_and(|m| self.steps[i] >= m);
            if o.done || cut {
                ended.push(i);
            }
            obs.push(o.cgm_mg_dl as f32);
            terminated.push(o.done);
            truncated.push(cut);
            for (c, v) in cols.iter_mut().zip(o.columns()) {
                c.push(v);
            }
        }
        let obs = numpy::ndarray::Array2::from_shape_vec((n, 1), obs).map_err(value_error)?;
        let [c0, c1, c2, c3, c4, c5] = cols;
        Ok((
            obs.into_pyarray(py),
            reward.into_pyarray(py),
            terminated.into_pyarray(py),
            truncated.into_pyarray(py),
            (!ended.is_empty()).then_some(ended),
            want_cgm.then(|| c0.into_pyarray(py)),
            c1.into_pyarray(py),
            c2.into_pyarray(py),
            c3.into_pyarray(py),
            c4.into_pyarray(py),
            c5.into_pyarray(py),
        ))
    }

    /// Number of environments.
    fn __len__(&self) -> usize {
        self.shards.iter().map(MinuteShard::len).sum()
    }

    /// Minutes per step.
    #[getter]
    fn sample_time_min(&self) -> u32 {
        self.sample_time_min
    }

    /// Time of day of every environment (minutes after midnight).
    #[getter]
    fn minute_of_day(&self) -> Vec<u32> {
        self.shards
            .iter()
            .flat_map(|s| (0..s.len()).map(|i| s.minute_of_day(i)))
            .collect()
    }
}

impl MinuteBatch {
    /// One step of every environment, `basal[i]` and `bolus[i]` for
    /// environment i (U/min): the shards on the cores, without the GIL.
    fn step_all(
        &mut self,
        py: Python<'_>,
        basal: &[f64],
        bolus: &[f64],
    ) -> PyResult<Vec<crate::minute_env::StepOut>> {
        let n = self.__len__();
        if basal.len() != n || bolus.len() != n {
            return Err(value_error(format!(
                "expected {n} actions, got {} basal and {} bolus",
                basal.len(),
                bolus.len()
            )));
        }
        let len = self.shard_len;
        let shards = &mut self.shards;
        let outs = py.allow_threads(|| {
            use rayon::prelude::*;
            let step = |(shard, (b, o)): (&mut MinuteShard, (&[f64], &[f64]))| shard.step(b, o);
            let work = shards
                .iter_mut()
                .zip(basal.chunks(len).zip(bolus.chunks(len)));
            if shards_len_one(len, n) {
                work.map(step).collect::<Vec<_>>()
            } else {
                shards
                    .par_iter_mut()
                    .zip(basal.par_chunks(len).zip(bolus.par_chunks(len)))
                    .map(step)
                    .collect()
            }
        });
        let mut all = Vec::with_capacity(n);
        for shard in outs {
            all.extend(shard.map_err(value_error)?);
        }
        Ok(all)
    }
}

/// Kovatchev's risk of one glucose value (mg/dL), LBGI + HBGI as
/// simglucose's `risk_index([bg], 1)` (and `abba.envs.risk_index`).
fn risk(bg_mg_dl: f64) -> f64 {
    // ln(bg)^1.084 as exp(1.084·ln(ln bg)): the same number within a few
    // ulp and, once per environment and step, 3 % of the vector
    // environment's time less than `powf` (glibc's pow).
    let f = 1.509 * ((1.084 * bg_mg_dl.max(1e-9).ln().ln()).exp() - 5.381);
    10.0 * f * f
}

/// True when a batch of `n` in shards of `len` is one shard.
fn shards_len_one(len: usize, n: usize) -> bool {
    len >= n
}

fn daily_sim(
    patient: &str,
    scenario: &str,
    days: u32,
    cohort_seed: u64,
    seed: u64,
) -> PyResult<DailySim> {
    let id: ScenarioId = scenario.parse().map_err(value_error)?;
    let mut config = ScenarioConfig::paper(id);
    config.days = days;
    let (vp, number) = cohort_patient(patient, cohort_seed)?;
    DailySim::new(vp, number, config, seed).map_err(value_error)
}

/// The seed paper's local cost of the day (eq13, c = a_hyper·F_hyper +
/// a_hypo·F_hypo with ABBA's default feature borders and weights 1 and 10),
/// from the day's device readings: the CGM's when it was worn, else the
/// meter's.
fn paper_cost(d: &DayOut) -> f64 {
    let weights = abba_advisor::config::AbbaConfig::new(abba_advisor::Mode::Cgm, 0);
    let cfg = weights.features;
    let cgm: Vec<f64> = d.cgm_mg_dl.iter().copied().filter(|g| *g > 0.0).collect();
    let (readings, mode): (Vec<f64>, abba_advisor::Mode) = if cgm.is_empty() {
        (
            d.smbg_mg_dl.iter().copied().filter(|g| *g > 0.0).collect(),
            abba_advisor::Mode::Smbg,
        )
    } else {
        (cgm, abba_advisor::Mode::Cgm)
    };
    let mut stats = abba_advisor::features::WindowStats::default();
    for g in readings {
        stats.push(g, &cfg);
    }
    abba_advisor::features::local_cost(&stats.features(&cfg, mode), weights.a_hyper, weights.a_hypo)
}

/// Metric `key` (e.g. `lbgi`) of `m`; NaN when undefined.
fn metric_of(m: Option<&abba_core::metrics::GlucoseMetrics>, key: &str) -> f64 {
    let metric = key.parse::<abba_core::Metric>().ok();
    m.zip(metric)
        .and_then(|(m, k)| m.get(k))
        .unwrap_or(f64::NAN)
}

fn day_dict<'py>(py: Python<'py>, d: DayOut) -> PyResult<Bound<'py, PyDict>> {
    let out = PyDict::new(py);
    let metrics = abba_core::metrics::metrics_regular(&d.plasma_mg_dl).ok();
    out.set_item("paper_cost", paper_cost(&d))?;
    out.set_item("day", d.day)?;
    out.set_item("cgm_mg_dl", d.cgm_mg_dl.into_pyarray(py))?;
    out.set_item("smbg_mg_dl", d.smbg_mg_dl.to_vec().into_pyarray(py))?;
    out.set_item("announced_carbs_g", d.announced_g.to_vec().into_pyarray(py))?;
    out.set_item("eaten_carbs_g", d.eaten_g)?;
    out.set_item("insulin_u", d.insulin_u)?;
    out.set_item("failed", d.failed)?;
    out.set_item("pump_capped", d.pump_capped)?;
    for key in [
        "lbgi",
        "hbgi",
        "tir_70_180",
        "below_70",
        "above_180",
        "mean_mg_dl",
    ] {
        out.set_item(key, metric_of(metrics.as_ref(), key))?;
    }
    out.set_item("plasma_mg_dl", d.plasma_mg_dl.into_pyarray(py))?;
    Ok(out)
}

/// One daily advisor environment.
#[pyclass(module = "abba._abba")]
pub struct DailyCore {
    sim: DailySim,
}

#[pymethods]
impl DailyCore {
    /// See `abba.envs.DailyAdvisorEnv`.
    #[new]
    #[pyo3(signature = (patient, scenario = "S1", days = 98, cohort_seed = 1, seed = 0))]
    fn new(
        patient: &str,
        scenario: &str,
        days: u32,
        cohort_seed: u64,
        seed: u64,
    ) -> PyResult<Self> {
        Ok(Self {
            sim: daily_sim(patient, scenario, days, cohort_seed, seed)?,
        })
    }

    /// Back to D1 with the streams of `seed`.
    fn reset(&mut self, seed: u64) -> PyResult<()> {
        self.sim.reset(seed).map_err(value_error)
    }

    /// Simulates the next day with these settings; returns what it recorded.
    fn day<'py>(
        &mut self,
        py: Python<'py>,
        basal_u_per_h: f64,
        carb_ratio_g_per_u: [f64; 3],
    ) -> PyResult<Bound<'py, PyDict>> {
        let d = self
            .sim
            .day(basal_u_per_h, carb_ratio_g_per_u)
            .map_err(value_error)?;
        day_dict(py, d)
    }

    /// Standard therapy: (basal U/h, carb ratio g/U).
    #[getter]
    fn standard_therapy(&self) -> (f64, f64) {
        let t = &self.sim.virtual_patient().therapy;
        (t.basal.0, t.carb_ratio[0].0)
    }

    /// CGM readings per day.
    #[getter]
    fn cgm_per_day(&self) -> usize {
        self.sim.cgm_per_day()
    }

    /// 0-based index of the next day.
    #[getter]
    fn next_day(&self) -> u32 {
        self.sim.next_day()
    }

    /// The patient's name.
    #[getter]
    fn patient_name(&self) -> String {
        self.sim.virtual_patient().params.name.clone()
    }
}

/// Many daily environments stepped in one call (in parallel).
#[pyclass(module = "abba._abba")]
pub struct DailyBatch {
    sims: Vec<DailySim>,
}

#[pymethods]
impl DailyBatch {
    /// `patients[i]` is environment i's patient, `seeds[i]` its first seed.
    #[new]
    #[pyo3(signature = (patients, seeds, scenario = "S1", days = 98, cohort_seed = 1))]
    fn new(
        patients: Vec<String>,
        seeds: Vec<u64>,
        scenario: &str,
        days: u32,
        cohort_seed: u64,
    ) -> PyResult<Self> {
        check_batch(&patients, &seeds)?;
        let sims = patients
            .iter()
            .zip(&seeds)
            .map(|(p, s)| daily_sim(p, scenario, days, cohort_seed, *s))
            .collect::<PyResult<_>>()?;
        Ok(Self { sims })
    }

    /// Back to D1 for environment `i`.
    fn reset_one(&mut self, i: usize, seed: u64) -> PyResult<()> {
        let n = self.sims.len();
        self.sims
            .get_mut(i)
            .ok_or_else(|| value_error(format!("environment {i} of {n}")))?
            .reset(seed)
            .map_err(value_error)
    }

    /// One day of environment `i` alone (e.g. the warm-up day after a reset).
    fn day_one<'py>(
        &mut self,
        py: Python<'py>,
        i: usize,
        settings: [f64; 4],
    ) -> PyResult<Bound<'py, PyDict>> {
        let n = self.sims.len();
        let sim = self
            .sims
            .get_mut(i)
            .ok_or_else(|| value_error(format!("environment {i} of {n}")))?;
        let d = sim
            .day(settings[0], [settings[1], settings[2], settings[3]])
            .map_err(value_error)?;
        day_dict(py, d)
    }

    /// Standard therapy of every environment as an (n, 4) array of
    /// (basal U/h, carb ratios g/U).
    fn standard_actions<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let rows: Vec<Vec<f64>> = self
            .sims
            .iter()
            .map(|s| {
                let t = &s.virtual_patient().therapy;
                vec![
                    t.basal.0,
                    t.carb_ratio[0].0,
                    t.carb_ratio[1].0,
                    t.carb_ratio[2].0,
                ]
            })
            .collect();
        PyArray2::from_vec2(py, &rows).map_err(value_error)
    }

    /// One day of every environment; `actions` is (n, 4): basal U/h and
    /// the three carb ratios g/U. Returns a dict of stacked arrays.
    fn step<'py>(
        &mut self,
        py: Python<'py>,
        actions: PyReadonlyArray2<'py, f64>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let a = actions.as_array();
        let n = self.sims.len();
        if a.shape() != [n, 4] {
            return Err(value_error(format!(
                "actions: expected shape ({n}, 4), got {:?}",
                a.shape()
            )));
        }
        let rows: Vec<[f64; 4]> = (0..n)
            .map(|i| [a[[i, 0]], a[[i, 1]], a[[i, 2]], a[[i, 3]]])
            .collect();
        let days: Vec<Result<DayOut, abba_sim::SimError>> = py.allow_threads(|| {
            use rayon::prelude::*;
            self.sims
                .par_iter_mut()
                .zip(rows.par_iter())
                .map(|(s, r)| s.day(r[0], [r[1], r[2], r[3]]))
                .collect()
        });
        let days = days
            .into_iter()
            .collect::<Result<Vec<_>, _>>()
            .map_err(value_error)?;
        let out = PyDict::new(py);
        let stack = |f: &dyn Fn(&DayOut) -> Vec<f64>| -> PyResult<Bound<'py, PyArray2<f64>>> {
            let rows: Vec<Vec<f64>> = days.iter().map(f).collect();
            PyArray2::from_vec2(py, &rows).map_err(value_error)
        };
        out.set_item("cgm_mg_dl", stack(&|d| d.cgm_mg_dl.clone())?)?;
        out.set_item("smbg_mg_dl", stack(&|d| d.smbg_mg_dl.to_vec())?)?;
        out.set_item("announced_carbs_g", stack(&|d| d.announced_g.to_vec())?)?;
        let metrics: Vec<Option<abba_core::metrics::GlucoseMetrics>> = py.allow_threads(|| {
            use rayon::prelude::*;
            days.par_iter()
                .map(|d| abba_core::metrics::metrics_regular(&d.plasma_mg_dl).ok())
                .collect()
        });
        let metric = |key: &str| -> Vec<f64> {
            metrics.iter().map(|m| metric_of(m.as_ref(), key)).collect()
        };
        for key in [
            "lbgi",
            "hbgi",
            "tir_70_180",
            "below_70",
            "above_180",
            "mean_mg_dl",
        ] {
            out.set_item(key, metric(key).into_pyarray(py))?;
        }
        out.set_item(
            "paper_cost",
            days.iter()
                .map(paper_cost)
                .collect::<Vec<_>>()
                .into_pyarray(py),
        )?;
        out.set_item(
            "insulin_u",
            days.iter()
                .map(|d| d.insulin_u)
                .collect::<Vec<_>>()
                .into_pyarray(py),
        )?;
        out.set_item(
            "failed",
            days.iter().map(|d| d.failed).collect::<Vec<bool>>(),
        )?;
        out.set_item("day", days.iter().map(|d| d.day).collect::<Vec<u32>>())?;
        Ok(out)
    }

    /// Number of environments.
    fn __len__(&self) -> usize {
        self.sims.len()
    }

    /// CGM readings per day.
    #[getter]
    fn cgm_per_day(&self) -> usize {
        self.sims.first().map_or(0, DailySim::cgm_per_day)
    }
}
