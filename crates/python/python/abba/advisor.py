"""The ABBA advisor for your own loop: feed it device events, read the
settings it answers with at decision points.

Research software, not a medical device.
"""

from __future__ import annotations

import json
from typing import Optional, Sequence, Union

from . import _abba

Settings = dict


def _settings(s) -> Optional[dict]:
    if s is None:
        return None
    basal, cr = s
    return {
        "basal_u_per_h": basal,
        "carb_ratio_g_per_u": {"breakfast": cr[0], "lunch": cr[1], "dinner": cr[2]},
    }


class Abba:
    """ABBA (Sun et al., IEEE JBHI 2019) in CGM or SMBG mode.

    Times are minutes since 00:00 of the person's first day; events must come
    in time order (readings, then meal announcements, then boluses and basal
    changes within one minute). Every method returns ``None``, or the
    settings in force after a decision point as
    ``{"basal_u_per_h": ..., "carb_ratio_g_per_u": {"breakfast": ..., ...}}``.
    Bad events raise ``ValueError`` and leave the advisor unchanged.
    The first 7 days keep the starting therapy (initialisation week).
    """

    def __init__(
        self,
        basal_u_per_h: float,
        carb_ratio_g_per_u: Union[float, Sequence[float]],
        mode: str = "cgm",
        exploration_seed: int = 0,
        config: Optional[dict] = None,
    ):
        if isinstance(carb_ratio_g_per_u, (int, float)):
            cr = [float(carb_ratio_g_per_u)] * 3
        else:
            cr = [float(x) for x in carb_ratio_g_per_u]
        self._core = _abba.AbbaCore(
            float(basal_u_per_h),
            cr,
            mode,
            exploration_seed,
            None if config is None else json.dumps(config),
        )

    def cgm(self, minute: int, mg_dl: float) -> Optional[dict]:
        """A CGM reading."""
        return _settings(self._core.cgm(minute, mg_dl))

    def smbg(self, minute: int, mg_dl: float) -> Optional[dict]:
        """A finger-stick (meter) reading."""
        return _settings(self._core.smbg(minute, mg_dl))

    def meal(self, minute: int, carbs_g: float, slot: str) -> Optional[dict]:
        """A meal announcement; slot is breakfast, lunch, dinner or snack.
        After a main meal's announcement, read that meal's carb ratio from
        ``settings`` to compute the bolus."""
        return _settings(self._core.meal(minute, carbs_g, slot))

    def bolus(self, minute: int, units: float) -> Optional[dict]:
        """Bolus insulin delivered (U)."""
        return _settings(self._core.bolus(minute, units))

    def basal(self, minute: int, u_per_h: float) -> Optional[dict]:
        """The basal rate in force from now on (U/h)."""
        return _settings(self._core.basal(minute, u_per_h))

    def day_closed(self, minute: int) -> Optional[dict]:
        """The day is over (SMBG mode: after the bedtime reading; CGM mode:
        at 00:00 of the next day). Answers with the next day's basal rate."""
        return _settings(self._core.day_closed(minute))

    @property
    def settings(self) -> dict:
        """The settings in force now."""
        return _settings(self._core.settings)

    @property
    def initialised(self) -> bool:
        """Whether the initialisation week is over."""
        return self._core.initialised

    def decisions(self) -> list[dict]:
        """The decisions since the last call, each with its explanation."""
        return [json.loads(d) for d in self._core.take_decisions_json()]

    def save(self) -> str:
        """The whole state as JSON; ``Abba.load`` resumes it exactly."""
        return self._core.save_json()

    @classmethod
    def load(cls, state: str) -> "Abba":
        """An advisor resumed from ``save()``."""
        obj = cls.__new__(cls)
        obj._core = _abba.AbbaCore.load_json(state)
        return obj
