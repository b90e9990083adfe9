"""Where real capture clips live: the data-directory setting."""
from __future__ import annotations

import os
from pathlib import Path

__all__ = ["data_dir", "ENV_VAR"]

#: environment variable naming the directory of real clips (e.g. ``../shared/data/mocap``)
ENV_VAR = "MOCOMP_DATA_DIR"


def data_dir(required: bool = False) -> Path | None:
    """The real-data directory, from ``$MOCOMP_DATA_DIR``.

    Returns ``None`` when unset (or raises :class:`~mocomp.errors.DataNotFoundError`
    with ``required=True``). A set but missing directory is always an error.
    """
    from ..errors import DataNotFoundError

    value = os.environ.get(ENV_VAR)
    if not value:
        if required:
            raise DataNotFoundError(
                f"no real-data directory: set {ENV_VAR} to the folder of capture clips "
                "(e.g. export MOCOMP_DATA_DIR=../shared/data/mocap)"
            )
        return None
    p = Path(value).expanduser().resolve()
    if not p.is_dir():
        raise DataNotFoundError(f"{ENV_VAR}={value!r} is not a directory (resolved to {p})")
    return p
