"""``motion_lag``: the fix is where the device was ``lag_s`` seconds before its stamp."""

from gps_error_ros.model.effect_kind import OneNumber
from gps_error_ros.model.section_spec import Field

#: The longest lag a profile may carry, s.
MAX_LAG_S = 10.0


class MotionLag(OneNumber):
    """The lag; the paths move the truth back by it (:mod:`~.motion_lag`), not the step."""

    name = 'motion_lag'
    summary = 'the fix is where the device was `lag_s` seconds before (the paths move the truth)'
    fields = (Field('lag_s', 'the lag, s', lo=0.0, hi=MAX_LAG_S, lo_open=True, digits=4),)
    order = 1
    none = 0.0


KIND = MotionLag()
