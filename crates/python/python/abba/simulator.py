"""Patients, cohorts and simulator runs (open loop, or a scenario with the
trial's closed loop)."""

from __future__ import annotations

import json
from typing import Optional

import numpy as np
import pandas as pd

from . import _abba

#: Units of every quantity the package takes or returns.
UNITS = {
    "glucose (plasma, subcutaneous, CGM, meter)": "mg/dL",
    "carbohydrate of a meal (carbs_g)": "g",
    "carbohydrate eaten (cho_g_per_min)": "g/min (a meal is eaten at 5 g/min)",
    "basal rate, our APIs (basal_u_per_h)": "U/h",
    "basal action of the simglucose-compatible env": "U/min (as simglucose)",
    "insulin infused per minute (insulin_u_per_min)": "U/min",
    "bolus (bolus_u)": "U",
    "carb ratio (carb_ratio_g_per_u)": "g/U",
    "time (minute)": "minutes since 00:00 of day 1 (trial) or since the episode start (env)",
    "insulin sensitivity s(t)": "1 = nominal (multiplies Vmx and kp3)",
}

#: The 13 model states and their units (Dalla Man 2007 / simglucose order).
STATE_UNITS = {
    "q_sto1": "mg",
    "q_sto2": "mg",
    "q_gut": "mg",
    "gp": "mg/kg",
    "gt": "mg/kg",
    "ip": "pmol/kg",
    "x": "pmol/L",
    "i1": "pmol/L",
    "id": "pmol/L",
    "il": "pmol/kg",
    "isc1": "pmol/kg",
    "isc2": "pmol/kg",
    "gs": "mg/kg",
}


def public_patients() -> list[str]:
    """The 30 public patients: adolescent#001-010, adult#001-010, child#001-010."""
    return list(_abba.public_patients())


def patient_params(name: str, cohort_seed: int = 1) -> pd.Series:
    """Every model parameter of a patient (public by name, or a cohort
    member such as ``adult#042`` of the cohort with ``cohort_seed``), with
    simglucose's column names (``BW`` kg, ``u2ss`` pmol/kg/min, ...)."""
    pairs = _abba.patient_params(name, cohort_seed)
    return pd.Series(dict(pairs), name=name)


def cohort(population: str = "adults", size: int = 100, seed: int = 1) -> pd.DataFrame:
    """A virtual cohort: one row per patient with its standard therapy
    (``basal_u_per_h``, ``carb_ratio_g_per_u``) and every parameter."""
    data = json.loads(_abba.cohort_json(population, size, seed))
    rows = []
    for p in data["patients"]:
        row = {
            "patient": p["params"]["name"],
            "basal_u_per_h": p["therapy"]["basal"],
            "carb_ratio_g_per_u": p["therapy"]["carb_ratio"][0],
            "origin": p["origin"] if isinstance(p["origin"], str) else next(iter(p["origin"])),
        }
        for k, v in p["params"].items():
            if k not in ("name", "x0"):
                row[k] = v
        rows.append(row)
    return pd.DataFrame(rows)


def simulate(
    patient: str,
    cho_g_per_min,
    insulin_u_per_min,
    sensitivity=None,
    cohort_seed: int = 1,
) -> pd.DataFrame:
    """Open-loop run, one row per minute 0..n: the patient eats
    ``cho_g_per_min[i]`` g/min and receives ``insulin_u_per_min[i]`` U/min
    during minute i (with optional insulin sensitivity, 1 = nominal).
    Returns plasma and subcutaneous glucose (mg/dL)."""
    cho = np.ascontiguousarray(cho_g_per_min, dtype=np.float64)
    ins = np.ascontiguousarray(insulin_u_per_min, dtype=np.float64)
    sens = None if sensitivity is None else np.ascontiguousarray(sensitivity, dtype=np.float64)
    g, gs = _abba.simulate(patient, cho, ins, sens, cohort_seed)
    return pd.DataFrame(
        {"minute": np.arange(len(g)), "plasma_mg_dl": g, "subcutaneous_mg_dl": gs}
    )


def run_scenario(
    patient: str = "adult#001",
    scenario: str = "S1",
    arm: str = "standard",
    config: Optional[dict] = None,
) -> pd.DataFrame:
    """One patient of a trial's cohort through one of the paper's scenarios
    (S1-S4) and arms (abba, standard, r2r) with the trial's closed loop:
    one row per simulated minute (glucose, CGM and meter readings, carbs
    eaten, insulin, sensitivity, settings in force). ``config`` is a trial
    configuration (see ``abba.trial.default_config()``)."""
    from .trial import _config_json

    cols = _abba.run_scenario(_config_json(config), patient, scenario, arm)
    return pd.DataFrame(dict(cols))
