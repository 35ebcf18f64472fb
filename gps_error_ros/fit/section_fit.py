"""
What fitting one optional section of a profile gives: the section, or why not, and the evidence.

``calibrate`` looks for the sections a recording can support beside the AR
fit (``availability``, ``velocity``, ``reported_accuracy``); each estimator
returns a :class:`SectionFit`. The evidence is what the profile's ``fit``
block records for the section (``fitted``, the counts it rests on, or the
``reason`` it was not fitted), so its keys are those of the JSON and YAML
the package writes.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Optional


@dataclass(frozen=True)
class SectionFit:
    """
    A profile section fitted from recordings, or not, with its evidence.

    Attributes
    ----------
    section : dict or None
        The section as plain data (its profile mapping), or None when the
        recordings do not support one.
    evidence : dict
        What the fit rests on, as written in the profile's ``fit`` block.

    """

    section: Optional[dict[str, Any]]
    evidence: dict[str, Any] = field(default_factory=dict)

    @property
    def fitted(self) -> bool:
        """Return True when a section was fitted."""
        return self.section is not None

    @property
    def reason(self) -> str:
        """Return why no section was fitted ('' when one was)."""
        return '' if self.fitted else str(self.evidence.get('reason', 'no section'))

    @classmethod
    def not_looked_for(cls) -> SectionFit:
        """Return the fit of a section nobody asked for."""
        return cls(None, {'fitted': False, 'reason': 'not looked for'})
