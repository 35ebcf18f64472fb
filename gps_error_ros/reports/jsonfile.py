"""Results written for people and programs: indented JSON."""

import json


def write_json(path, data):
    """Write ``data`` as indented JSON."""
    with open(path, 'w', encoding='utf-8') as f:
        json.dump(data, f, indent=2)
        f.write('\n')
