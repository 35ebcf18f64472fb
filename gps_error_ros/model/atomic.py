"""
Outputs that appear whole or not at all: written aside, then renamed.

At the bottom of the house because every wing writes files this way, the
profile writer of :mod:`.profiles` included.
"""

from contextlib import contextmanager
import os
from pathlib import Path
from typing import Iterator, Union

#: A file's path, as a string or a path object.
PathArg = Union[str, 'os.PathLike[str]']


@contextmanager
def atomic_output(path: str | os.PathLike[str]) -> Iterator[Path]:
    """
    Yield a temporary path beside ``path``; rename it to ``path`` on success.

    On any error (or Ctrl-C) the temporary file is removed and ``path`` is
    left as it was: a failed run leaves no partial output behind.
    """
    path = Path(path)
    tmp = path.with_name(f'.{path.name}.partial-{os.getpid()}')
    try:
        yield tmp
        os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()
