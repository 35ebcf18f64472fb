"""The error node's agents that share one profile, and the engine that steps them."""

from dataclasses import dataclass

import numpy as np

from gps_error_ros.model.state import AgentState
from gps_error_ros.sim.engine import FixEngine


@dataclass
class ProfileGroup:
    """The agents that share one profile, and the engine that steps them."""

    engine: FixEngine[AgentState]   # the profile's model, chosen at run time
    members: np.ndarray        # node-wide agent indices, in engine order
    covariance: list[float]    # row-major ENU m^2 of the published fixes
    covariance_type: int
    profile: str               # the profile parameter's value for these agents
    carries: str = ''          # what the profile carries (the start-up line says it)
