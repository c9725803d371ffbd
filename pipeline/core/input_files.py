"""Files a user names as input: regular files of a bounded size, checked before anything
reads them (a driver table at ``/dev/zero`` would be read for ever, a 600 MB STEP file
imported for minutes).

Examples
--------
>>> import tempfile, pathlib
>>> p = pathlib.Path(tempfile.mkdtemp()) / "t.csv"
>>> _ = p.write_text("0, 1\\n1, 2\\n")
>>> input_file(p, "driver table", MAX_TABLE_BYTES) == p
True
"""

from __future__ import annotations

import os
import stat
from pathlib import Path

from pipeline.core.errors import ConfigError

__all__ = ["MAX_CAD_BYTES", "MAX_SCRIPT_BYTES", "MAX_TABLE_BYTES", "input_file"]

#: a driver or force table (CSV)
MAX_TABLE_BYTES = 64 * 2**20
#: a CAD file (STEP) of one link
MAX_CAD_BYTES = 100 * 2**20
#: a gmsh script (.geo)
MAX_SCRIPT_BYTES = 8 * 2**20


def input_file(path: str | os.PathLike, what: str, max_bytes: int) -> Path:
    """``path`` if it is a regular file (after symbolic links) of at most ``max_bytes``;
    else ConfigError naming it, ``what`` it is and why."""
    p = Path(path)
    try:
        st = os.stat(p)
    except FileNotFoundError:
        raise ConfigError(f"{p}: {what} not found") from None
    except OSError as exc:
        raise ConfigError(f"{p}: cannot read the {what}: {exc.strerror}") from None
    if not stat.S_ISREG(st.st_mode):
        raise ConfigError(f"{p}: the {what} is not a regular file (a device, a pipe or a "
                          f"folder); give a file")
    if st.st_size > max_bytes:
        raise ConfigError(f"{p}: the {what} is {st.st_size / 2**20:.1f} MB; at most "
                          f"{max_bytes / 2**20:g} MB is read")
    return p
