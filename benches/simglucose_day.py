"""Times one simulated patient-day of simglucose's UVA/Padova patient model,
for comparison with abba's `patient_day` criterion benchmark.

Drives simglucose's patient directly, minute by minute, with the paper's
standard day (meals 50/60/80/15 g at 07:00/12:00/18:30/23:00, boluses CHO/CR
for the three main meals, steady-state basal) -- the same day as
`cargo bench -p abba-sim --bench patient_day`. Also checks that the final
plasma glucose agrees with abba's (`abba simulate --day standard`).

    python3 -m venv /tmp/sg && /tmp/sg/bin/pip install simglucose==0.2.11
    /tmp/sg/bin/python benches/simglucose_day.py [repeats]

Also times one patient-day of simglucose's own simulation, as its users
run it (`sim_engine.sim` of a `SimObj`: `T1DSimEnv` with the Dexcom CGM,
the Insulet pump and a `RandomScenario`, driven by its `BBController`, 3-min
sample time, results kept in memory), adult#001, seed 1.
"""
import sys
import time

from simglucose.patient.t1dpatient import Action, T1DPatient


def one_day(name="adult#001", cr=10.0):
    patient = T1DPatient.withName(name)
    basal = patient._params.u2ss * patient._params.BW / 6000.0
    meals = {420: 50.0, 720: 60.0, 1110: 80.0, 1380: 15.0}
    for minute in range(1440):
        grams = meals.get(minute, 0.0)
        bolus = grams / cr if minute != 1380 else 0.0
        patient.step(Action(CHO=grams, insulin=basal + bolus))
    return patient.state[3] / patient._params.Vg


def one_simulated_day():
    import contextlib
    import io
    from datetime import datetime, timedelta

    from simglucose.actuator.pump import InsulinPump
    from simglucose.controller.basal_bolus_ctrller import BBController
    from simglucose.sensor.cgm import CGMSensor
    from simglucose.simulation.env import T1DSimEnv
    from simglucose.simulation.scenario_gen import RandomScenario
    from simglucose.simulation.sim_engine import SimObj

    start = datetime(2018, 1, 1)
    env = T1DSimEnv(
        T1DPatient.withName("adult#001"),
        CGMSensor.withName("Dexcom", seed=1),
        InsulinPump.withName("Insulet"),
        RandomScenario(start_time=start, seed=1),
    )
    run = SimObj(env, BBController(), timedelta(days=1), animate=False, path=None)
    with contextlib.redirect_stdout(io.StringIO()):
        run.simulate()
    return run.results()


def timed(run, repeats):
    """The sorted wall times of `repeats` calls of `run`, and its last result."""
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        result = run()
        times.append(time.perf_counter() - start)
    return sorted(times), result


def main():
    repeats = int(sys.argv[1]) if len(sys.argv) > 1 else 3
    times, g = timed(one_day, repeats)
    print(f"simglucose 0.2.11, adult#001 standard day: median {times[len(times) // 2]:.3f} s "
          f"per patient-day over {repeats} runs (min {times[0]:.3f} s); final G = {g:.4f} mg/dL")
    full, results = timed(one_simulated_day, repeats)
    print(f"simglucose 0.2.11, its own simulation (T1DSimEnv, BBController, RandomScenario): median "
          f"{full[len(full) // 2]:.3f} s per patient-day over {repeats} runs (min {full[0]:.3f} s); "
          f"{len(results)} samples")


if __name__ == "__main__":
    main()
