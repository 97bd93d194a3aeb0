"""Reference values of iglu-python for iglu's example subject.

How `iglu_example_data_1_subject.iglu_python.json` was made (once, by hand;
the tests only read the JSON):

    python3 -m venv venv && venv/bin/pip install iglu-python==0.4.3
    TZ=UTC venv/bin/python iglu_example_reference.py

The per-segment table, and the "service" and "max" directions derived from
it (iglu-python 0.4.3 raises on those two directions for this subject), were
added to the JSON from `mage(df, return_type="df")`, printed below.
"""
import json
import platform
import warnings

import numpy
import pandas as pd
import iglu_python as iglu

warnings.filterwarnings("ignore")
df = pd.read_csv("iglu_example_data_1_subject.csv")[["id", "time", "gl"]]
df["time"] = pd.to_datetime(df["time"])
df["gl"] = df["gl"].astype(float)


def v(frame, column):
    return float(frame[column].iloc[0])


out = {
    "input": "iglu_example_data_1_subject.csv",
    "package": "iglu-python 0.4.3",
    "python": platform.python_version(),
    "pandas": pd.__version__,
    "numpy": numpy.__version__,
    "TZ_env": "UTC",
    "iglu": {
        "mean_glu": v(iglu.mean_glu(df), "mean"),
        "sd_glu": v(iglu.sd_glu(df), "SD"),
        "cv_glu": v(iglu.cv_glu(df), "CV"),
        "gmi": v(iglu.gmi(df), "GMI"),
        "lbgi": v(iglu.lbgi(df), "LBGI"),
        "hbgi": v(iglu.hbgi(df), "HBGI"),
        "in_range_percent_70_180": v(iglu.in_range_percent(df), "in_range_70_180"),
        "below_54": v(iglu.below_percent(df), "below_54"),
        "below_70": v(iglu.below_percent(df), "below_70"),
        "above_180": v(iglu.above_percent(df), "above_180"),
        "above_250": v(iglu.above_percent(df), "above_250"),
        "mage_default": v(iglu.mage(df), "MAGE"),
        "mage_ma_plus": v(iglu.mage(df, direction="plus"), "MAGE"),
        "mage_ma_minus": v(iglu.mage(df, direction="minus"), "MAGE"),
    },
}
print(iglu.mage(df, return_type="df").to_string())
print(json.dumps(out, indent=2))
