"""The gymnasium environments: registered on import, gymnasium's own
checker passes, seeding on reset is honoured, the vector forms match the
single environments' spaces and reset finished sub-environments."""

import gymnasium
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import abba
from abba.envs import (
    DailyAdvisorEnv,
    DailyAdvisorVectorEnv,
    T1DSimEnv,
    T1DSimVectorEnv,
    risk_diff,
)


def test_registered_on_import():
    ids = gymnasium.envs.registration.registry
    assert "abba/T1DSim-v0" in ids and "abba/DailyAdvisor-v0" in ids
    env = gymnasium.make("abba/T1DSim-v0", patient_name="adult#002")
    assert isinstance(env.unwrapped, T1DSimEnv)
    assert env.spec.max_episode_steps == 480


@pytest.mark.parametrize(
    "make",
    [
        lambda: T1DSimEnv(patient_name="adult#001"),
        lambda: T1DSimEnv(patient_name=["child#002", "adolescent#004"], bolus_action=True),
        lambda: gymnasium.make("abba/T1DSim-v0", patient_name="adult#003").unwrapped,
        lambda: DailyAdvisorEnv(patient="adult#004", scenario="S1", days=12),
        lambda: DailyAdvisorEnv(patient="adult#005", scenario="S4", days=12),
        lambda: gymnasium.make("abba/DailyAdvisor-v0", patient="adult#001").unwrapped,
    ],
)
def test_gymnasium_env_checker_passes(make):
    check_env(make(), skip_render_check=True)


def rollout(env, seed, steps, action):
    obs, _ = env.reset(seed=seed)
    out = [obs]
    for _ in range(steps):
        obs, r, term, trunc, info = env.step(action)
        out.append(obs)
        out.append(np.array([r]))
    return np.concatenate([np.ravel(o) for o in out])


def test_minute_env_reset_seed_is_honoured():
    env = T1DSimEnv(patient_name="adult#001")
    a = rollout(env, 5, 200, np.array([0.02], np.float32))
    b = rollout(env, 5, 200, np.array([0.02], np.float32))
    c = rollout(env, 6, 200, np.array([0.02], np.float32))
    assert np.array_equal(a, b)
    assert not np.array_equal(a, c)
    # A fresh environment with the same reset seed gives the same episode.
    d = rollout(T1DSimEnv(patient_name="adult#001"), 5, 200, np.array([0.02], np.float32))
    assert np.array_equal(a, d)


def test_minute_env_units_and_simglucose_semantics():
    env = T1DSimEnv(patient_name="adult#001", meals=[(30, 50.0)], random_init_bg=False,
                    start_minute_of_day=420)
    obs, info = env.reset(seed=1)
    assert env.sample_time == 3 and info["minute_of_day"] == 420
    assert env.action_space.high[0] == 30.0  # U/min, simglucose's Insulet pump
    meals, eaten = [], []
    for _ in range(20):
        obs, r, term, trunc, info = env.step(np.array([0.0], np.float32))
        meals.append(info["meal"])
        eaten.append(info["cho_g_per_min"] * 3)
        assert info["insulin_u_per_min"] == 0.0
    # The 50 g meal starts at minute 30 (step 10): simglucose's `meal` is
    # the announced grams / 3 min in that step; it is eaten at 5 g/min.
    assert meals[10] == pytest.approx(50.0 / 3) and sum(meals) == pytest.approx(50.0 / 3)
    assert sum(eaten) == pytest.approx(50.0)
    assert info["minute"] == 60 and info["minute_of_day"] == 480
    # Custom rewards get the last hour of CGM readings (20 at 3 min).
    seen = []
    env = T1DSimEnv(patient_name="adult#001", reward_fun=lambda h: seen.append(len(h)) or 0.0)
    env.reset(seed=2)
    for _ in range(25):
        env.step(np.array([0.01], np.float32))
    assert seen[0] == 2 and seen[-1] == 20


def test_minute_env_terminates_like_simglucose():
    # No insulin and a big meal: glucose rises past 600 mg/dL eventually; a
    # large insulin rate drives it below 10. Both end the episode.
    env = T1DSimEnv(patient_name="child#001", random_init_bg=False)
    env.reset(seed=0)
    for k in range(2000):
        obs, r, term, trunc, info = env.step(np.array([5.0], np.float32))
        if term:
            break
    assert term and info["bg"] < 10


def test_daily_env_days_actions_and_rewards():
    env = DailyAdvisorEnv(patient="adult#002", scenario="S2", days=12)
    obs, day1 = env.reset(seed=3)
    assert day1["day"] == 1 and obs["cgm_mg_dl"].shape == (288,)
    assert (obs["cgm_mg_dl"] > 0).all()  # CGM worn on D1-D8 in S2
    action = env.standard_action
    for d in range(2, 12):
        obs, reward, term, trunc, info = env.step(action)
        assert info["day"] == d and not term
        assert reward == pytest.approx(-(info["lbgi"] + info["hbgi"]))
        if d > 8:
            assert (obs["cgm_mg_dl"] == 0).all() and (obs["smbg_mg_dl"] > 0).all()
        assert trunc == (d == 12)
    obs, reward, term, trunc, info = env.step(action)
    assert trunc
    # The paper's cost: 0 when every reading is within 90-150 mg/dL, and
    # hypoglycaemia weighs ten times hyperglycaemia.
    cost_env = DailyAdvisorEnv(patient="adult#002", scenario="S1", days=5, reward="neg_paper_cost")
    cost_env.reset(seed=1)
    _, r, _, _, info = cost_env.step(cost_env.standard_action)
    cgm = info["cgm_mg_dl"]
    hyper = np.clip(cgm - 150, 0, None)
    hypo = np.clip(90 - cgm, 0, None)
    # CGM mode's default features: the time-averaged excursion (sum over
    # every reading / number of readings), normalised by 350-150 (adults'
    # CGM G_max) and 90-40.
    f_hyper = min(1.0, hyper.sum() / len(cgm) / 200)
    f_hypo = min(1.0, hypo.sum() / len(cgm) / 50)
    assert r == pytest.approx(-(f_hyper + 10 * f_hypo), rel=1e-9)
    # More insulin: lower mean glucose on the same day (same seed).
    means = []
    for scale in (1.0, 1.4):
        env.reset(seed=9)
        a = env.standard_action.copy()
        a[0] *= scale
        means.append(env.step(a)[4]["mean_mg_dl"])
    assert means[1] < means[0]


def test_vector_minute_env_steps_all_and_autoresets():
    v = T1DSimVectorEnv(3, patient_name=["adult#001", "child#001", "adolescent#001"], seed=4,
                        max_episode_steps=10)
    assert v.single_observation_space == T1DSimEnv(patient_name="adult#001").observation_space
    obs, _ = v.reset(seed=1)
    assert obs.shape == (3, 1) and obs.dtype == np.float32
    for k in range(10):
        obs, r, term, trunc, info = v.step(np.full((3, 1), 0.01))
        assert obs.shape == (3, 1) and r.shape == (3,)
    assert trunc.all() and "final_observation" in info
    # After the same-step reset the reward's previous reading is the new
    # episode's first (the observation returned at the truncation; float32,
    # 1e-5 mg/dL apart from the reading the reward uses, and the risk moves
    # by at most 0.3 per mg/dL: 3e-6).
    obs2, r2, *_ = v.step(np.full((3, 1), 0.01))
    for i in range(3):
        assert r2[i] == pytest.approx(risk_diff([obs[i, 0], obs2[i, 0]]), abs=6e-6)
        last = info["final_observation"][i][0]
        assert r2[i] != pytest.approx(risk_diff([last, obs2[i, 0]]), abs=6e-6)
    # Same seed, same batch.
    w = T1DSimVectorEnv(3, patient_name=["adult#001", "child#001", "adolescent#001"], seed=4)
    a, _ = w.reset(seed=1)
    b, _ = T1DSimVectorEnv(3, patient_name=["adult#001", "child#001", "adolescent#001"]).reset(seed=1)
    assert np.array_equal(a, b)
    # Default rewards are simglucose's risk_diff of each environment's CGM.
    obs1, r1, *_ = w.step(np.full((3, 1), 0.01))
    for i in range(3):
        assert r1[i] == pytest.approx(risk_diff([a[i, 0], obs1[i, 0]]), rel=1e-5, abs=1e-6)


def test_vector_minute_env_matches_single_env_glucose():
    # With fixed meals and initial state, the batch and a single env see the
    # same patient trajectory (BG does not depend on the noise seed).
    kw = dict(meals=[(60, 40.0)], random_init_bg=False, start_minute_of_day=360)
    v = T1DSimVectorEnv(2, patient_name="adult#007", seed=1, **kw)
    v.reset(seed=1)
    s = T1DSimEnv(patient_name="adult#007", **kw)
    s.reset(seed=99)
    for k in range(60):
        _, _, _, _, vi = v.step(np.full((2, 1), 0.015))
        _, _, _, _, si = s.step(np.array([0.015], np.float32))
        assert vi["bg"][0] == si["bg"] == vi["bg"][1]


def test_vector_daily_env_matches_single_daily_envs():
    names = ["adult#001", "adult#002"]
    v = DailyAdvisorVectorEnv(2, patient=names, scenario="S3", days=10, seed=5)
    obs, _ = v.reset(seed=5)
    assert obs["cgm_mg_dl"].shape == (2, 288)
    actions = v.standard_actions * np.array([1.1, 1.0, 0.9, 1.0])
    out, r, term, trunc, info = v.step(actions)
    assert r.shape == (2,) and not term.any()
    # Each sub-environment is the daily env of that patient with the seed
    # the batch drew for it: the same actions give the same days.
    seeds = np.random.default_rng(5)
    for i, name in enumerate(names):
        e = DailyAdvisorEnv(patient=name, scenario="S3", days=10)
        e.core.reset(int(seeds.integers(0, 2**63 - 1)))
        std = v.standard_actions[i]
        e.core.day(float(std[0]), [float(x) for x in std[1:]])
        d = e.core.day(float(actions[i, 0]), [float(x) for x in actions[i, 1:]])
        assert np.array_equal(np.asarray(d["smbg_mg_dl"], np.float32), out["smbg_mg_dl"][i])
        assert -(d["lbgi"] + d["hbgi"]) == r[i]


def test_make_vec_builds_the_vector_forms():
    # gymnasium 0.29 calls the vector entry point "custom" (1.x:
    # "vector_entry_point"); options go through vector_kwargs.
    mode = "custom" if gymnasium.__version__.startswith("0.") else "vector_entry_point"
    v = gymnasium.make_vec("abba/T1DSim-v0", num_envs=4, vectorization_mode=mode,
                           vector_kwargs={"patient_name": "adult#005"})
    assert isinstance(v, T1DSimVectorEnv) and v.patient_names == ["adult#005"] * 4
    assert v.max_episode_steps == 480
    d = gymnasium.make_vec("abba/DailyAdvisor-v0", num_envs=2, vectorization_mode=mode,
                           vector_kwargs={"days": 5})
    assert isinstance(d, DailyAdvisorVectorEnv)
    obs, _ = d.reset(seed=0)
    for k in range(4):
        obs, r, term, trunc, info = d.step(d.standard_actions)
    assert trunc.all()


def test_vector_minute_env_patients_are_the_same_in_any_company_and_alone():
    # 70 environments step as PatientBatch lanes, in one shard per core; an
    # environment's every output is the same, to the bit, in a batch of
    # its own (so neither its neighbours nor the number of cores matter),
    # and its glucose within 1e-9 mg/dL of the single environment's (the
    # batch's exp of kempt's tanh is within 2 ulp of libm's).
    from abba import _abba

    names = [f"{g}#{k:03d}" for g in ("adult", "adolescent", "child") for k in range(1, 11)]
    names = (names * 3)[:70]
    seeds = [1000 + 7 * i for i in range(70)]
    kw = dict(meals=[(30, 50.0), (300, 70.0)], start_minute_of_day=420)
    big = _abba.MinuteBatch(names, seeds, **kw)
    picks = [0, 17, 33, 69]
    alone = [_abba.MinuteBatch([names[i]], [seeds[i]], **kw) for i in picks]
    single = [_abba.MinuteCore(names[i], seed=seeds[i], **kw) for i in picks]
    rng = np.random.default_rng(3)
    for step in range(200):
        basal = rng.uniform(0.0, 0.05, 70)
        bolus = np.where(rng.uniform(size=70) < 0.02, 0.5, 0.0)
        if step == 120:
            # A new episode for one environment mid-run (an autoreset).
            big.reset_one(17, 4242)
            alone[1].reset_one(0, 4242)
            single[1].reset(4242)
        out = big.step(basal, bolus)
        for k, i in enumerate(picks):
            mine = alone[k].step(basal[i : i + 1], bolus[i : i + 1])
            for a, b in zip(out, mine):
                assert a[i] == b[0], (step, i)
            cgm, bg, plasma, *_ = single[k].step(float(basal[i]), float(bolus[i]))
            assert abs(bg - out[1][i]) < 1e-9 and abs(plasma - out[2][i]) < 1e-9, (step, i)
            assert abs(cgm - out[0][i]) < 1e-9, (step, i)


def test_vector_minute_env_random_meals_follow_simglucose_random_scenario():
    # simglucose's RandomScenario: breakfast, lunch and dinner with
    # probability 0.95 (45, 70, 80 g on average), three snacks with 0.3
    # (10 g): 194.25 g a day on average, breakfast between 05:00 and 09:00.
    # Three days of 64 environments from midnight (a fixed seed: the same
    # draws every run; 4 standard errors either side of the mean).
    n, steps_per_day = 64, 480
    v = T1DSimVectorEnv(n, patient_name="adult#001", seed=7, start_minute_of_day=0,
                        max_episode_steps=None)
    v.reset(seed=7)
    grams = np.zeros((n, 3))
    breakfasts = np.zeros((n, 3), dtype=int)
    for k in range(3 * steps_per_day):
        _, _, term, _, info = v.step(np.full((n, 1), 0.02))
        assert not term.any()
        day, minute = divmod(k * 3, 1440)
        announced = info["meal"] * 3
        grams[:, day] += announced
        if 300 <= minute < 540:
            breakfasts[:, day] += announced > 20
    assert 185.0 <= grams.mean() <= 204.0, grams.mean()
    assert (breakfasts <= 1).all()
    assert 0.9 <= breakfasts.mean() <= 1.0
    # Every day has its own draws.
    assert len({tuple(np.round(grams[:, d], 6)) for d in range(3)}) == 3


def test_vector_minute_env_reward_fun_sees_each_environments_last_hour():
    # A custom reward gets each environment's readings since its reset, at
    # most an hour (20 at 3 min), oldest first; with simglucose's
    # risk_diff it gives the default reward.
    kw = dict(patient_name=["adult#001", "child#002"], seed=3, max_episode_steps=30)
    seen = []

    def reward(hour):
        seen.append(len(hour))
        return risk_diff(hour)

    custom = T1DSimVectorEnv(2, reward_fun=reward, **kw)
    default = T1DSimVectorEnv(2, **kw)
    custom.reset(seed=5)
    default.reset(seed=5)
    for k in range(35):
        _, rc, _, trunc_c, _ = custom.step(np.full((2, 1), 0.01))
        _, rd, _, trunc_d, _ = default.step(np.full((2, 1), 0.01))
        assert rc == pytest.approx(rd, rel=1e-9, abs=1e-12), k
        assert (trunc_c == trunc_d).all()
    # Two environments a step; 2, 3, ... readings, at most 20; after the
    # truncation at step 30 the history starts again from the new reading.
    assert seen[:4] == [2, 2, 3, 3]
    assert max(seen) == 20 and seen[2 * 29] == 20 and seen[2 * 30] == 2
