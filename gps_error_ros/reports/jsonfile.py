"""Results written for people and programs: indented JSON."""

import json
from typing import Any

from gps_error_ros.model.atomic import PathArg


def write_json(path: PathArg, data: Any) -> None:
    """Write ``data`` as indented JSON."""
    with open(path, 'w', encoding='utf-8') as f:
        json.dump(data, f, indent=2)
        f.write('\n')
