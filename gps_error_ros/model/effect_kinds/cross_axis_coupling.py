"""``cross_axis_coupling``: the north and east innovations are correlated."""

from gps_error_ros.model.ar_model import AxisParams
from gps_error_ros.model.effect_kind import OneNumber


class CrossAxisCoupling(OneNumber):
    """The innovations' correlation ``innovation_corr``, in the AR part's own draw."""

    name = 'cross_axis_coupling'
    keys = ('innovation_corr',)
    summary = 'the north and east innovations are correlated'
    order = 0
    lo, hi, lo_open, digits, none = -0.99, 0.99, False, 6, 0.0

    def ar(self, params: float, north: AxisParams, east: AxisParams,
           corr: float) -> tuple[AxisParams, AxisParams, float]:
        """Return the axes, and the correlation of their innovations."""
        return north, east, params


KIND = CrossAxisCoupling()
