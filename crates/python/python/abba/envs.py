"""gymnasium environments (registered on ``import abba``):

- ``abba/T1DSim-v0`` (:class:`T1DSimEnv`): per CGM sample, a drop-in for
  simglucose 0.2.11's ``T1DSimGymnaisumEnv``: observation the CGM reading
  (mg/dL), action the basal insulin rate in **U/min** (simglucose's unit),
  one step = one CGM sample time (3 min with the default Dexcom sensor),
  episode ends when the step's mean subcutaneous glucose is below 10 or
  above 600 mg/dL, the same ``reward_fun`` option (default: simglucose's
  ``risk_diff``), and ``reset(seed=...)`` honoured. Limited to 480 steps
  (one day at 3 min) by the registration.
- ``abba/DailyAdvisor-v0`` (:class:`DailyAdvisorEnv`): one step = one day of
  one of the paper's scenarios; action the day's basal rate (U/h) and three
  carb ratios (g/U); observation the day's CGM or meter readings and the
  announced meals; reward configurable (default −(LBGI + HBGI) of the day's
  plasma glucose).
- :class:`T1DSimVectorEnv` and :class:`DailyAdvisorVectorEnv`: gymnasium
  ``VectorEnv`` forms that step every patient in one call into the
  simulator (``gymnasium.make_vec(id, num_envs=...)``). They reset a
  finished sub-environment in the same step (gymnasium 0.29's autoreset;
  the last observation is in ``infos["final_observation"]``).

Research software, not a medical device.
"""

from __future__ import annotations

import math
from datetime import datetime, timedelta
from typing import Callable, Optional, Sequence, Union

import gymnasium
import numpy as np
from gymnasium import spaces

from . import _abba

__all__ = [
    "T1DSimEnv",
    "T1DSimVectorEnv",
    "DailyAdvisorEnv",
    "DailyAdvisorVectorEnv",
    "risk_index",
    "risk_diff",
    "REWARDS",
]


def risk_index(bg_mg_dl: float) -> tuple[float, float, float]:
    """Kovatchev's risk of one glucose value: (LBGI, HBGI, LBGI + HBGI),
    computed as simglucose's ``risk_index([bg], 1)``."""
    f = 1.509 * (math.log(bg_mg_dl) ** 1.084 - 5.381)
    r = 10.0 * f * f
    return (r, 0.0, r) if f < 0 else ((0.0, r, r) if f > 0 else (0.0, 0.0, 0.0))


def risk_diff(bg_last_hour: Sequence[float]) -> float:
    """simglucose's default reward: the risk of the previous CGM reading
    minus that of the current one (0 with fewer than two)."""
    if len(bg_last_hour) < 2:
        return 0.0
    return risk_index(bg_last_hour[-2])[2] - risk_index(bg_last_hour[-1])[2]


def _reset_rng(env: gymnasium.Env, seed: Optional[int]) -> None:
    """Seeds ``env.np_random`` as gymnasium does; on the first reset without a
    seed, the constructor's seed (``env._ctor_rng``) decides."""
    gymnasium.Env.reset(env, seed=seed)
    if seed is None and not hasattr(env, "_seeded"):
        env.np_random = env._ctor_rng
    env._seeded = True


def _vector_rng(seed: Union[int, Sequence[int]]) -> np.random.Generator:
    """The generator of a vector environment's ``reset(seed=...)``."""
    return np.random.default_rng(seed if isinstance(seed, int) else list(seed))


def _seed(rng: np.random.Generator) -> int:
    return int(rng.integers(0, 2**63 - 1))


def _meals_from(custom_scenario, meals):
    """(meals as [(minute, grams)], start minute of day) from our ``meals``
    or a simglucose ``CustomScenario`` (times in hours, timedelta or
    datetime, relative to its ``start_time``)."""
    if meals is not None:
        return [(int(m), float(g)) for m, g in meals], None
    if custom_scenario is None:
        return None, None
    start = getattr(custom_scenario, "start_time", None)
    out = []
    for t, action in custom_scenario.scenario:
        grams = float(getattr(action, "meal", action))
        if isinstance(t, (int, float)):
            minute = round(t * 60.0)
        elif isinstance(t, timedelta):
            minute = round(t.total_seconds() / 60.0)
        elif isinstance(t, datetime):
            minute = round((t - start).total_seconds() / 60.0)
        else:
            raise ValueError(f"custom_scenario: time {t!r} is not hours, timedelta or datetime")
        out.append((minute, grams))
    start_min = None if start is None else start.hour * 60 + start.minute
    return out, start_min


class T1DSimEnv(gymnasium.Env):
    """The simglucose-compatible environment (see the module docs).

    Arguments as simglucose's ``T1DSimGymnaisumEnv``: ``patient_name`` (a
    name or a list to draw from at each reset; public patients or cohort
    members such as ``adult#042``), ``custom_scenario`` (a simglucose
    ``CustomScenario``; default: random meals drawn like simglucose's
    ``RandomScenario``), ``reward_fun`` (called with the CGM readings of the
    last hour, newest last), ``seed``. Extensions: ``meals`` (list of
    (minutes after the episode start, grams)), ``sensor`` (Dexcom,
    GuardianRT, Navigator), ``pump`` (Insulet, Cozmo), ``random_init_bg``
    (simglucose draws the initial glucose states; True by default),
    ``init_state`` (13 initial states, see ``abba.STATE_UNITS``),
    ``start_minute_of_day``, ``bolus_action`` (action = [basal U/min,
    bolus U/min]).

    ``info`` has simglucose's keys (``bg`` = mean subcutaneous glucose over
    the step, mg/dL; ``lbgi``, ``hbgi``, ``risk``; ``meal`` = grams of the
    meals that started in the step / its minutes, as simglucose;
    ``sample_time`` min, ``patient_name``) and ``plasma_mg_dl``,
    ``insulin_u_per_min``, ``minute``, ``minute_of_day``.
    """

    metadata = {"render_modes": []}
    MAX_BG = 1000

    def __init__(
        self,
        patient_name: Union[str, Sequence[str], None] = None,
        custom_scenario=None,
        reward_fun: Optional[Callable[[Sequence[float]], float]] = None,
        seed: Optional[int] = None,
        render_mode: Optional[str] = None,
        *,
        meals: Optional[Sequence[tuple[int, float]]] = None,
        sensor: str = "Dexcom",
        pump: str = "Insulet",
        random_init_bg: bool = True,
        init_state: Optional[Sequence[float]] = None,
        start_minute_of_day: Optional[int] = None,
        bolus_action: bool = False,
        cohort_seed: int = 1,
    ):
        super().__init__()
        if render_mode is not None:
            raise ValueError("render_mode: abba's environments do not render")
        self.render_mode = None
        self.patient_names = (
            ["adolescent#001"]
            if patient_name is None
            else ([patient_name] if isinstance(patient_name, str) else list(patient_name))
        )
        self.reward_fun = reward_fun or risk_diff
        meal_list, scenario_start = _meals_from(custom_scenario, meals)
        if start_minute_of_day is None:
            start_minute_of_day = scenario_start
        self._kwargs = dict(
            sensor=sensor,
            pump=pump,
            meals=meal_list,
            random_init_bg=random_init_bg,
            init_state=None if init_state is None else [float(x) for x in init_state],
            start_minute_of_day=start_minute_of_day,
            cohort_seed=cohort_seed,
        )
        self._cores: dict = {}
        self._ctor_rng = np.random.default_rng(seed)
        self.core = self._core(self.patient_names[0])
        self.sample_time = self.core.sample_time_min
        self.bolus_action = bolus_action
        self.observation_space = spaces.Box(low=0, high=self.MAX_BG, shape=(1,), dtype=np.float32)
        hi = self.core.max_basal_u_per_min
        self.action_space = spaces.Box(
            low=0, high=hi, shape=(2 if bolus_action else 1,), dtype=np.float32
        )
        self._window = max(1, int(60 / self.sample_time))
        self._cgm_hist: list[float] = []

    def _info(self, name, meal, cho, bg, plasma, insulin, minute) -> dict:
        """The ``info`` of a reset or a step (see the class docs)."""
        lbgi, hbgi, risk = risk_index(bg) if bg > 0 else (float("inf"), 0.0, float("inf"))
        return {
            "sample_time": self.sample_time,
            "patient_name": name,
            "meal": meal,
            "cho_g_per_min": cho,
            "bg": bg,
            "lbgi": lbgi,
            "hbgi": hbgi,
            "risk": risk,
            "plasma_mg_dl": plasma,
            "insulin_u_per_min": insulin,
            "minute": minute,
            "minute_of_day": self.core.minute_of_day,
        }

    def _core(self, name: str):
        if name not in self._cores:
            self._cores[name] = _abba.MinuteCore(name, seed=0, **self._kwargs)
        return self._cores[name]

    @property
    def max_basal(self) -> float:
        """Largest basal rate of the pump (U/min)."""
        return self.core.max_basal_u_per_min

    def reset(self, *, seed: Optional[int] = None, options: Optional[dict] = None):
        _reset_rng(self, seed)
        name = self.patient_names[int(self.np_random.integers(len(self.patient_names)))]
        self.core = self._core(name)
        cgm = self.core.reset(_seed(self.np_random))
        self._cgm_hist = [cgm]
        info = self._info(name, 0.0, 0.0, self.core.bg_mg_dl, self.core.plasma_mg_dl, 0.0, 0)
        return np.array([cgm], dtype=np.float32), info

    def step(self, action):
        a = np.asarray(action, dtype=np.float64).reshape(-1)
        basal = float(a[0])
        bolus = float(a[1]) if self.bolus_action else 0.0
        cgm, bg, plasma, meal, cho, insulin, done = self.core.step(basal, bolus)
        self._cgm_hist.append(cgm)
        if len(self._cgm_hist) > self._window:
            del self._cgm_hist[: len(self._cgm_hist) - self._window]
        reward = float(self.reward_fun(list(self._cgm_hist)))
        info = self._info(self.core.patient_name, meal, cho, bg, plasma, insulin, self.core.minute)
        return np.array([cgm], dtype=np.float32), reward, bool(done), False, info


class T1DSimVectorEnv(gymnasium.vector.VectorEnv):
    """``num_envs`` simglucose-compatible environments stepped in one call.

    ``patient_name`` is one name for all, or one per environment. Actions
    are an array of shape (num_envs, 1) of basal rates in U/min (or
    (num_envs, 2) with ``bolus_action``). ``max_episode_steps`` (default
    480, one day at 3 min) truncates an episode; a finished environment is
    reset in the same step. Rewards: simglucose's ``risk_diff`` unless
    ``reward_fun`` is given (called per environment with its last hour of
    CGM readings).
    """

    metadata = {"autoreset_mode": "same-step"}

    def __init__(
        self,
        num_envs: int = 1,
        patient_name: Union[str, Sequence[str], None] = None,
        custom_scenario=None,
        reward_fun: Optional[Callable[[Sequence[float]], float]] = None,
        seed: Optional[int] = None,
        *,
        meals: Optional[Sequence[tuple[int, float]]] = None,
        sensor: str = "Dexcom",
        pump: str = "Insulet",
        random_init_bg: bool = True,
        start_minute_of_day: Optional[int] = None,
        bolus_action: bool = False,
        max_episode_steps: Optional[int] = 480,
        cohort_seed: int = 1,
    ):
        if patient_name is None:
            names = ["adolescent#001"] * num_envs
        elif isinstance(patient_name, str):
            names = [patient_name] * num_envs
        else:
            names = list(patient_name)
            if len(names) != num_envs:
                raise ValueError(f"{len(names)} patient names for {num_envs} environments")
        meal_list, scenario_start = _meals_from(custom_scenario, meals)
        if start_minute_of_day is None:
            start_minute_of_day = scenario_start
        self._rng = np.random.default_rng(seed)
        self.batch = _abba.MinuteBatch(
            names,
            [_seed(self._rng) for _ in names],
            sensor=sensor,
            pump=pump,
            meals=meal_list,
            random_init_bg=random_init_bg,
            start_minute_of_day=start_minute_of_day,
            cohort_seed=cohort_seed,
        )
        self.num_envs = num_envs
        self.patient_names = names
        self.sample_time = self.batch.sample_time_min
        self.bolus_action = bolus_action
        self.reward_fun = reward_fun
        self.max_episode_steps = max_episode_steps
        single_obs = spaces.Box(low=0, high=T1DSimEnv.MAX_BG, shape=(1,), dtype=np.float32)
        max_basal = 35.0 if pump == "Cozmo" else 30.0
        single_act = spaces.Box(
            low=0, high=max_basal, shape=(2 if bolus_action else 1,), dtype=np.float32
        )
        self.single_observation_space = single_obs
        self.single_action_space = single_act
        self.observation_space = gymnasium.vector.utils.batch_space(single_obs, num_envs)
        self.action_space = gymnasium.vector.utils.batch_space(single_act, num_envs)
        self.is_vector_env = True
        self.closed = False
        self.viewer = None
        self.render_mode = None
        self.spec = None
        self._window = max(1, int(60 / self.sample_time))
        # The last hour of CGM readings, for a reward_fun only: a ring
        # whose newest column is self._pos (no copy of the whole window per
        # step). The default reward needs only the previous reading's risk.
        self._hist = np.zeros((num_envs, self._window))
        self._pos = self._window - 1
        self._count = np.zeros(num_envs, dtype=np.int64)
        # The info masks (every environment reports every key), shared
        # read-only between steps.
        self._all = np.ones(num_envs, dtype=bool)
        self._all.flags.writeable = False

    def _reset_one(self, i: int) -> float:
        # The batch restarts the environment's step count and the risk of
        # its last reading (the reward's previous term) itself.
        cgm = self.batch.reset_one(i, _seed(self._rng))
        self._hist[i, self._pos] = cgm
        self._count[i] = 1
        return cgm

    def _last_hour(self, i: int) -> list:
        """Environment i's readings since its reset, at most an hour, oldest first."""
        n = int(self._count[i])
        cols = [(self._pos - k) % self._window for k in range(n - 1, -1, -1)]
        return list(self._hist[i, cols])

    def reset(self, *, seed: Optional[Union[int, Sequence[int]]] = None, options=None):
        if seed is not None:
            self._rng = _vector_rng(seed)
        obs = np.array([self._reset_one(i) for i in range(self.num_envs)], dtype=np.float32)
        return obs.reshape(self.num_envs, 1), {}

    def step(self, actions):
        # The batch steps every environment and keeps the episodes' books
        # (step counts, truncation, the default reward): one call instead
        # of a dozen numpy operations per step.
        a = np.asarray(actions, dtype=np.float64).reshape(self.num_envs, -1)
        custom = self.reward_fun is not None
        (obs, rewards, terminated, truncated, ended, cgm,
         bg, plasma, meal, cho, insulin) = self.batch.step_gym(
            a, self.bolus_action, self.max_episode_steps, not custom and self._window > 1, custom
        )
        if custom:
            self._pos = (self._pos + 1) % self._window
            self._hist[:, self._pos] = cgm
            np.minimum(self._count + 1, self._window, out=self._count)
            rewards = np.array(
                [float(self.reward_fun(self._last_hour(i))) for i in range(self.num_envs)]
            )
        infos = {
            "bg": bg,
            "plasma_mg_dl": plasma,
            "meal": meal,
            "cho_g_per_min": cho,
            "insulin_u_per_min": insulin,
            "_bg": self._all,
            "_plasma_mg_dl": self._all,
            "_meal": self._all,
            "_cho_g_per_min": self._all,
            "_insulin_u_per_min": self._all,
        }
        if ended:
            final_obs = np.full(self.num_envs, None, dtype=object)
            mask = np.zeros(self.num_envs, dtype=bool)
            for i in ended:
                final_obs[i] = obs[i].copy()
                mask[i] = True
                obs[i, 0] = self._reset_one(i)
            infos["final_observation"] = final_obs
            infos["_final_observation"] = mask
            infos["final_info"] = np.array([{} if m else None for m in mask], dtype=object)
            infos["_final_info"] = mask
        return obs, rewards, terminated, truncated, infos

    def close_extras(self, **kwargs):
        pass


def _neg_lbgi_hbgi(day: dict) -> float:
    return -(day["lbgi"] + day["hbgi"])


def _tir(day: dict) -> float:
    return day["tir_70_180"] / 100.0


def _neg_paper_cost(day: dict) -> float:
    return -day["paper_cost"]


#: Named rewards of the daily environment (each takes the day's record).
REWARDS: dict[str, Callable[[dict], float]] = {
    "neg_lbgi_hbgi": _neg_lbgi_hbgi,
    "tir": _tir,
    "neg_paper_cost": _neg_paper_cost,
}

#: Action bounds of the daily environment: basal U/h, carb ratios g/U.
DAILY_ACTION_LOW = np.array([0.0, 1.0, 1.0, 1.0], dtype=np.float32)
DAILY_ACTION_HIGH = np.array([10.0, 100.0, 100.0, 100.0], dtype=np.float32)


def _daily_obs_space(cgm_per_day: int) -> spaces.Dict:
    return spaces.Dict(
        {
            "cgm_mg_dl": spaces.Box(0.0, 600.0, (cgm_per_day,), np.float32),
            "smbg_mg_dl": spaces.Box(0.0, 600.0, (4,), np.float32),
            "announced_carbs_g": spaces.Box(0.0, 1000.0, (3,), np.float32),
            "settings": spaces.Box(0.0, 100.0, (4,), np.float32),
        }
    )


def _daily_obs(day: dict, settings: np.ndarray) -> dict:
    return {
        "cgm_mg_dl": np.asarray(day["cgm_mg_dl"], dtype=np.float32),
        "smbg_mg_dl": np.asarray(day["smbg_mg_dl"], dtype=np.float32),
        "announced_carbs_g": np.asarray(day["announced_carbs_g"], dtype=np.float32),
        "settings": np.asarray(settings, dtype=np.float32),
    }


class DailyAdvisorEnv(gymnasium.Env):
    """One day per step of one of the paper's scenarios (S1: CGM all days;
    S2-S4: CGM for D1-D8, then four meter readings a day; S3 adds time
    jitter, S4 skipped meals), for advisors like ABBA.

    - ``reset`` simulates D1 (the warm-up day) with the patient's standard
      therapy and returns what the devices recorded.
    - action: ``[basal_u_per_h, carb_ratio_breakfast_g_per_u,
      carb_ratio_lunch_g_per_u, carb_ratio_dinner_g_per_u]`` for the next
      day (bounds ``DAILY_ACTION_LOW``/``HIGH``); each main meal is bolused
      announced carbs / its carb ratio through the trial's pump.
    - observation (dict): ``cgm_mg_dl`` (every CGM sample of the day, 0 where
      none), ``smbg_mg_dl`` (before breakfast, lunch, dinner, bedtime; 0
      where none), ``announced_carbs_g`` (breakfast, lunch, dinner; 0 if
      skipped), ``settings`` (the action in force that day).
    - reward: ``"neg_lbgi_hbgi"`` (default, −(LBGI + HBGI) of plasma glucose
      every 5 min of the day), ``"tir"``, ``"neg_paper_cost"`` (minus the
      seed paper's eq13 cost a_hyper·F_hyper + a_hypo·F_hypo of the day's
      device readings, ABBA's default borders 90/150 mg/dL and weights 1
      and 10), or any callable taking the day's record (``info``: lbgi, hbgi, tir_70_180, below_70, above_180,
      mean_mg_dl, insulin_u, plasma_mg_dl, ...).
    - terminated when plasma glucose falls below 10 mg/dL (the trial's
      failure rule); truncated after ``days`` − 1 steps.
    """

    metadata = {"render_modes": []}

    def __init__(
        self,
        patient: str = "adult#001",
        scenario: str = "S1",
        days: int = 98,
        reward: Union[str, Callable[[dict], float]] = "neg_lbgi_hbgi",
        cohort_seed: int = 1,
        seed: Optional[int] = None,
        render_mode: Optional[str] = None,
    ):
        super().__init__()
        if render_mode is not None:
            raise ValueError("render_mode: abba's environments do not render")
        self.render_mode = None
        self.core = _abba.DailyCore(patient, scenario, days, cohort_seed, 0)
        self.days = days
        self.reward_fn = REWARDS[reward] if isinstance(reward, str) else reward
        basal, cr = self.core.standard_therapy
        self.standard_action = np.array([basal, cr, cr, cr], dtype=np.float32)
        self.observation_space = _daily_obs_space(self.core.cgm_per_day)
        self.action_space = spaces.Box(DAILY_ACTION_LOW, DAILY_ACTION_HIGH, dtype=np.float32)
        self._ctor_rng = np.random.default_rng(seed)

    def reset(self, *, seed: Optional[int] = None, options: Optional[dict] = None):
        _reset_rng(self, seed)
        self.core.reset(_seed(self.np_random) % (2**63))
        a = self.standard_action.astype(np.float64)
        day = self.core.day(float(a[0]), [float(x) for x in a[1:]])
        return _daily_obs(day, a), day

    def step(self, action):
        a = np.asarray(action, dtype=np.float64).reshape(4)
        day = self.core.day(float(a[0]), [float(x) for x in a[1:]])
        reward = float(self.reward_fn(day))
        terminated = bool(day["failed"])
        truncated = (not terminated) and self.core.next_day >= self.days
        return _daily_obs(day, a), reward, terminated, truncated, day


class DailyAdvisorVectorEnv(gymnasium.vector.VectorEnv):
    """``num_envs`` daily environments (one patient each) stepped in one
    call, in parallel on every core. ``patient`` is a name for all or one
    per environment (e.g. ``[f"adult#{i:03d}" for i in range(1, 101)]``).
    Observations are the dict of :class:`DailyAdvisorEnv` with a leading
    batch dimension; actions an array (num_envs, 4). An episode is truncated
    after ``days`` − 1 steps (or ``max_episode_steps``)."""

    metadata = {"autoreset_mode": "same-step"}

    def __init__(
        self,
        num_envs: int = 1,
        patient: Union[str, Sequence[str]] = "adult#001",
        scenario: str = "S1",
        days: int = 98,
        reward: Union[str, Callable[[dict], float]] = "neg_lbgi_hbgi",
        cohort_seed: int = 1,
        seed: Optional[int] = None,
        max_episode_steps: Optional[int] = None,
    ):
        names = [patient] * num_envs if isinstance(patient, str) else list(patient)
        if len(names) != num_envs:
            raise ValueError(f"{len(names)} patients for {num_envs} environments")
        self._rng = np.random.default_rng(seed)
        self.batch = _abba.DailyBatch(
            names, [_seed(self._rng) for _ in names], scenario, days, cohort_seed
        )
        self.num_envs = num_envs
        self.days = days
        # Steps after the warm-up day: days - 1 at most.
        self.max_steps = days - 1 if max_episode_steps is None else min(max_episode_steps, days - 1)
        self.reward = reward
        self.standard_actions = np.asarray(self.batch.standard_actions())
        single_obs = _daily_obs_space(self.batch.cgm_per_day)
        single_act = spaces.Box(DAILY_ACTION_LOW, DAILY_ACTION_HIGH, dtype=np.float32)
        self.single_observation_space = single_obs
        self.single_action_space = single_act
        self.observation_space = gymnasium.vector.utils.batch_space(single_obs, num_envs)
        self.action_space = gymnasium.vector.utils.batch_space(single_act, num_envs)
        self.is_vector_env = True
        self.closed = False
        self.viewer = None
        self.render_mode = None
        self.spec = None
        self._day = np.zeros(num_envs, dtype=np.int64)

    def _obs(self, out: dict, actions: np.ndarray) -> dict:
        return {
            "cgm_mg_dl": out["cgm_mg_dl"].astype(np.float32),
            "smbg_mg_dl": out["smbg_mg_dl"].astype(np.float32),
            "announced_carbs_g": out["announced_carbs_g"].astype(np.float32),
            "settings": actions.astype(np.float32),
        }

    def _rewards(self, out: dict) -> np.ndarray:
        if self.reward == "neg_lbgi_hbgi":
            return -(out["lbgi"] + out["hbgi"])
        if self.reward == "tir":
            return out["tir_70_180"] / 100.0
        if self.reward == "neg_paper_cost":
            return -out["paper_cost"]
        days = [
            {k: (v[i] if hasattr(v, "__len__") else v) for k, v in out.items()}
            for i in range(self.num_envs)
        ]
        return np.array([float(self.reward(d)) for d in days])

    def reset(self, *, seed=None, options=None):
        if seed is not None:
            self._rng = _vector_rng(seed)
        for i in range(self.num_envs):
            self.batch.reset_one(i, _seed(self._rng))
        self._day[:] = 0
        a = self.standard_actions
        out = self.batch.step(np.ascontiguousarray(a, dtype=np.float64))
        self._day += 1
        return self._obs(out, a), {}

    def step(self, actions):
        a = np.ascontiguousarray(np.asarray(actions, dtype=np.float64).reshape(self.num_envs, 4))
        out = self.batch.step(a)
        self._day += 1
        rewards = self._rewards(out).astype(np.float64)
        terminated = np.asarray(out["failed"], dtype=bool)
        truncated = (self._day - 1 >= self.max_steps) & ~terminated
        obs = self._obs(out, a)
        infos = {k: out[k] for k in ("lbgi", "hbgi", "tir_70_180", "insulin_u")}
        for k in list(infos):
            infos["_" + k] = np.ones(self.num_envs, dtype=bool)
        ended = np.flatnonzero(terminated | truncated)
        if ended.size:
            final_obs = np.full(self.num_envs, None, dtype=object)
            mask = np.zeros(self.num_envs, dtype=bool)
            for i in ended:
                final_obs[i] = {k: v[i].copy() for k, v in obs.items()}
                mask[i] = True
                self.batch.reset_one(int(i), _seed(self._rng))
                self._day[i] = 0
            # The reset sub-environments live their warm-up day now (the
            # others are not stepped): their observation is that day.
            std = self.standard_actions
            warm = self.batch_warmup(ended, std)
            for k in obs:
                obs[k][ended] = warm[k]
            infos["final_observation"] = final_obs
            infos["_final_observation"] = mask
        return obs, rewards, terminated, truncated, infos

    def batch_warmup(self, idx: np.ndarray, std: np.ndarray) -> dict:
        """Warm-up days (standard therapy) of the sub-environments ``idx``
        just reset, each stepped alone."""
        out = {k: [] for k in ("cgm_mg_dl", "smbg_mg_dl", "announced_carbs_g", "settings")}
        for i in idx:
            d = self.batch.day_one(int(i), [float(x) for x in std[i]])
            o = _daily_obs(d, std[i])
            for k in out:
                out[k].append(o[k])
            self._day[i] = 1
        return {k: np.stack(v) for k, v in out.items()}

    def close_extras(self, **kwargs):
        pass


def _register() -> None:
    reg = gymnasium.envs.registration.registry
    if "abba/T1DSim-v0" not in reg:
        gymnasium.register(
            id="abba/T1DSim-v0",
            entry_point="abba.envs:T1DSimEnv",
            vector_entry_point="abba.envs:T1DSimVectorEnv",
            max_episode_steps=480,
        )
    if "abba/DailyAdvisor-v0" not in reg:
        gymnasium.register(
            id="abba/DailyAdvisor-v0",
            entry_point="abba.envs:DailyAdvisorEnv",
            vector_entry_point="abba.envs:DailyAdvisorVectorEnv",
            max_episode_steps=97,
        )
