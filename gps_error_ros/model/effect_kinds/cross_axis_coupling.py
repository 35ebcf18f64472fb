"""``cross_axis_coupling``: the north and east innovations are correlated."""

from gps_error_ros.model.ar_model import AxisParams
from gps_error_ros.model.effect_kind import OneNumber
from gps_error_ros.model.section_spec import Field


class CrossAxisCoupling(OneNumber):
    """The innovations' correlation ``innovation_corr``, in the AR part's own draw."""

    name = 'cross_axis_coupling'
    summary = 'the north and east innovations are correlated'
    fields = (Field('innovation_corr', 'the correlation of the north and east innovations',
                    lo=-0.99, hi=0.99, digits=6),)
    order = 0
    none = 0.0

    def ar(self, params: float, north: AxisParams, east: AxisParams,
           corr: float) -> tuple[AxisParams, AxisParams, float]:
        """Return the axes, and the correlation of their innovations."""
        return north, east, params


KIND = CrossAxisCoupling()
