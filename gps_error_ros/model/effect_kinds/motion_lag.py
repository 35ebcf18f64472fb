"""``motion_lag``: the fix is where the device was ``lag_s`` seconds before its stamp."""

from typing import Any

from gps_error_ros.model.effect_kind import EffectKind, Section

#: The longest lag a profile may carry, s.
MAX_LAG_S = 10.0


class MotionLag(EffectKind[float]):
    """The lag; the paths move the truth back by it (:mod:`~.motion_lag`), not the step."""

    name = 'motion_lag'
    keys = ('lag_s',)
    summary = 'the fix is where the device was `lag_s` seconds before (the paths move the truth)'
    order = 1

    def parse(self, section: Section) -> float:
        """Return the lag, in (0, MAX_LAG_S] s."""
        return section.number('lag_s', 0.0, MAX_LAG_S)

    def to_dict(self, params: float) -> dict[str, Any]:
        """Return the section."""
        return {'lag_s': round(float(params), 4)}

    def absent(self, params: float) -> bool:
        """Return True for no lag."""
        return params == 0.0

    def default(self) -> float:
        """Return 0 s: no lag."""
        return 0.0


KIND = MotionLag()
