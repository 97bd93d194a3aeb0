"""abba: the UVA/Padova type 1 diabetes simulator (as simglucose computes it,
thousands of times faster), gymnasium environments, the ABBA advisor and the
paper's in-silico trial, with sweeps on Dask.

Research software, not a medical device: nothing here is a treatment advice.

Units are in every name: glucose in mg/dL (``*_mg_dl``), carbohydrate in g
(``carbs_g``) or g/min (``cho_g_per_min``), insulin in U (``*_u``), U/h
(``*_u_per_h``) or U/min (``*_u_per_min``), carb ratios in g/U, time in
minutes. See ``abba.UNITS``.
"""

from . import _abba
from ._abba import GIT_REVISION, __version__
from .simulator import (
    STATE_UNITS,
    UNITS,
    cohort,
    patient_params,
    public_patients,
    run_scenario,
    simulate,
)
from . import advisor, envs, sweep, trial
from .advisor import Abba

DISCLAIMER = "abba is research software, not a medical device."

__all__ = [
    "Abba",
    "DISCLAIMER",
    "GIT_REVISION",
    "STATE_UNITS",
    "UNITS",
    "__version__",
    "advisor",
    "cohort",
    "envs",
    "patient_params",
    "public_patients",
    "run_scenario",
    "simulate",
    "sweep",
    "trial",
]

envs._register()
