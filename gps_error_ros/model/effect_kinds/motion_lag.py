"""``motion_lag``: the fix is where the device was ``lag_s`` seconds before its stamp."""

from gps_error_ros.model.effect_kind import OneNumber

#: The longest lag a profile may carry, s.
MAX_LAG_S = 10.0


class MotionLag(OneNumber):
    """The lag; the paths move the truth back by it (:mod:`~.motion_lag`), not the step."""

    name = 'motion_lag'
    keys = ('lag_s',)
    summary = 'the fix is where the device was `lag_s` seconds before (the paths move the truth)'
    order = 1
    lo, hi, digits, none = 0.0, MAX_LAG_S, 4, 0.0


KIND = MotionLag()
