"""
What the error node says of its truth: the frame of its poses, and steps it could not serve.

Poses are taken as ENU metres about the datum: the frame of parameter
``truth_frame`` (``map`` by default; '' checks nothing). A pose stamped in
another frame (``base_link``, ``odom``) is taken as it is, with one warning
per frame name, or dropped with ``other_frames: refuse``; either way it is
counted on ``/diagnostics``.

Steps that got no fix for want of truth are named by their cause: truth
that came too late (``/clock`` runs ahead of the poses: raise
``max_pose_age``) or truth that was invalid (non-finite poses, dropped).
"""

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from gps_error_ros.model.state import BoolArray
from gps_error_ros.ros import cdr
from gps_error_ros.ros.parameters import WARN_PERIOD_S


class TruthFrame:
    """
    Check the truth's ``header.frame_id`` against the expected frame (see the module doc).

    Parameters
    ----------
    node
        The node whose logger warns.
    expected
        The frame the poses should be in ('' checks nothing).
    refuse
        Drop a pose in another frame (else take it, and warn once per frame).

    """

    def __init__(self, node: Any, expected: str, refuse: bool) -> None:
        self.node = node
        self.expected = expected
        self.refuse = refuse
        #: poses seen in another frame
        self.others = 0
        self.warned: set[str] = set()
        self.late_reported = self.gaps_reported = 0

    @classmethod
    def of(cls, node: Any, cfg: Mapping[str, Any], input_type: str) -> 'TruthFrame':
        """Return the check of parameters ``truth_frame`` and ``other_frames`` (none for fixes)."""
        return cls(node, '' if input_type == 'navsatfix' else cfg['truth_frame'].strip(),
                   cfg['other_frames'] == 'refuse')

    def warn_of_gaps(self, late: int, gaps: int, max_pose_age: float) -> None:
        """Warn when more steps went without a fix, by cause: truth too late, or invalid."""
        log = self.node.get_logger()
        if late > self.late_reported:
            self.late_reported = late
            log.warning(f'steps got no fix although their truth came, more than max_pose_age '
                        f'({max_pose_age:g} s of the ROS clock) after the step: /clock runs '
                        f'ahead of the poses; raise max_pose_age to the largest lead',
                        throttle_duration_sec=WARN_PERIOD_S)
        if gaps > self.gaps_reported:
            self.gaps_reported = gaps
            log.warning('steps got no fix while an agent\'s truth was invalid (non-finite '
                        'positions or a zero quaternion, dropped): the node publishes nothing '
                        'for those steps, not NO_FIX; fixes resume with valid truth',
                        throttle_duration_sec=WARN_PERIOD_S)

    def keep(self, frame: str) -> bool:
        """Return whether to keep a pose stamped in ``frame`` (counted and warned if other)."""
        if not self.expected or frame == self.expected:
            return True
        self._other(frame, 1)
        return not self.refuse

    def keep_batch(self, raws: Sequence[bytes]) -> BoolArray:
        """Return which serialized poses to keep (the others counted, their frame warned)."""
        if not self.expected:
            return np.ones(len(raws), dtype=bool)
        same = cdr.frame_ids_are(raws, self.expected)
        if not same.all():
            first = int(np.flatnonzero(~same)[0])
            self._other(cdr.frame_id(raws[first]), int((~same).sum()))
        return same if self.refuse else np.ones(len(raws), dtype=bool)

    def _other(self, frame: str, count: int) -> None:
        """Count ``count`` poses in another frame; warn the first time ``frame`` is seen."""
        self.others += count
        if frame in self.warned:
            return
        self.warned.add(frame)
        what = 'dropped' if self.refuse else 'taken as ENU metres about the datum'
        self.node.get_logger().warning(
            f'truth pose in frame {frame!r}, expected {self.expected!r} (parameter '
            f'truth_frame): {what}. Publish the truth in {self.expected!r}, or set '
            f'truth_frame to the frame your poses are in (the datum is its origin)')
