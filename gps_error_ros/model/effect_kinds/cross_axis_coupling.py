"""``cross_axis_coupling``: the north and east innovations are correlated."""

from typing import Any

from gps_error_ros.model.ar_model import AxisParams
from gps_error_ros.model.effect_kind import EffectKind, Section


class CrossAxisCoupling(EffectKind[float]):
    """The innovations' correlation ``innovation_corr``, in the AR part's own draw."""

    name = 'cross_axis_coupling'
    keys = ('innovation_corr',)
    summary = 'the north and east innovations are correlated'
    order = 0

    def parse(self, section: Section) -> float:
        """Return the correlation, in [-0.99, 0.99]."""
        return section.number('innovation_corr', -0.99, 0.99, lo_open=False)

    def to_dict(self, params: float) -> dict[str, Any]:
        """Return the section."""
        return {'innovation_corr': round(float(params), 6)}

    def ar(self, params: float, north: AxisParams, east: AxisParams,
           corr: float) -> tuple[AxisParams, AxisParams, float]:
        """Return the axes, and the correlation of their innovations."""
        return north, east, params

    def absent(self, params: float) -> bool:
        """Return True for no correlation."""
        return params == 0.0

    def default(self) -> float:
        """Return 0: uncorrelated."""
        return 0.0


KIND = CrossAxisCoupling()
