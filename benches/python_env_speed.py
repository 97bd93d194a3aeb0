"""Environment steps per second, in one run: simglucose 0.2.11's gymnasium
environment, abba's simglucose-compatible environment, and abba's
vectorised form; plus simulated days per second of the daily advisor
environment, single and vectorised.

One step of the per-sample environments is one CGM sample (3 min with the
default Dexcom sensor), the same in all three. Random meals and random
initial glucose (each environment's default), a constant basal rate.

    python3 -m venv /tmp/abba-py && /tmp/abba-py/bin/pip install ./crates/python simglucose==0.2.11
    /tmp/abba-py/bin/python benches/python_env_speed.py
"""

import time

import numpy as np

import abba
from abba.envs import DailyAdvisorEnv, DailyAdvisorVectorEnv, T1DSimEnv, T1DSimVectorEnv


def rate(n_steps, fn):
    t0 = time.perf_counter()
    fn()
    return n_steps / (time.perf_counter() - t0)


def simglucose_env(steps):
    from simglucose.envs import T1DSimGymnaisumEnv

    env = T1DSimGymnaisumEnv(patient_name="adult#001", seed=1)
    env.reset()

    def run():
        for _ in range(steps):
            _, _, done, _, _ = env.step(0.02)
            if done:
                env.reset()

    return rate(steps, run)


def abba_env(steps):
    env = T1DSimEnv(patient_name="adult#001", seed=1)
    env.reset(seed=1)
    a = np.array([0.02], np.float32)

    def run():
        for _ in range(steps):
            _, _, term, _, _ = env.step(a)
            if term:
                env.reset()

    return rate(steps, run)


def abba_vector(num_envs, steps):
    env = T1DSimVectorEnv(num_envs, patient_name="adult#001", seed=1, max_episode_steps=None)
    env.reset(seed=1)
    a = np.full((num_envs, 1), 0.02)

    def run():
        for _ in range(steps):
            env.step(a)

    return rate(num_envs * steps, run)


def daily(days):
    env = DailyAdvisorEnv(patient="adult#001", days=days + 1)
    env.reset(seed=1)

    def run():
        for _ in range(days):
            env.step(env.standard_action)

    return rate(days, run)


def daily_vector(num_envs, days):
    names = [f"adult#{i:03d}" for i in range(1, num_envs + 1)]
    env = DailyAdvisorVectorEnv(num_envs, patient=names, days=days + 1, seed=1)
    env.reset(seed=1)

    def run():
        for _ in range(days):
            env.step(env.standard_actions)

    return rate(num_envs * days, run)


def main():
    # Three rounds, each measuring simglucose and then abba's environments
    # right after it: on a shared machine the load moves between minutes,
    # so each round's ratio is taken within the round, and the medians are
    # printed with their range.
    print(f"abba {abba.__version__} ({abba.GIT_REVISION})")
    rows = {}
    for _ in range(3):
        sg = simglucose_env(480)
        rows.setdefault("simglucose 0.2.11 T1DSimGymnaisumEnv:", []).append((sg, 1.0))
        ours = abba_env(48_000)
        rows.setdefault("abba T1DSimEnv:", []).append((ours, ours / sg))
        for n in (64, 256, 1024):
            vec = abba_vector(n, 480)
            rows.setdefault(f"abba T1DSimVectorEnv ({n} envs):", []).append((vec, vec / sg))
    for label, runs in rows.items():
        rates = sorted(r for r, _ in runs)
        ratios = sorted(x for _, x in runs)
        print(
            f"{label:38}{rates[1]:12,.0f} steps/s ({rates[0]:,.0f}-{rates[-1]:,.0f}); "
            f"x simglucose: median {ratios[1]:,.0f} ({ratios[0]:,.0f}-{ratios[-1]:,.0f})"
        )
    d1 = daily(90)
    dv = daily_vector(32, 30)
    print(f"abba DailyAdvisorEnv:                 {d1:12,.0f} days/s")
    print(f"abba DailyAdvisorVectorEnv (32 envs): {dv:12,.0f} days/s")


if __name__ == "__main__":
    main()
