"""Checks of the paths a command will write, made before anything starts."""

from __future__ import annotations

import tempfile
from pathlib import Path


def unwritable_dir(directory: Path) -> str | None:
    """Why files cannot be written into `directory` (created if missing), or None when they
    can: a folder that cannot be created, is not a folder, or refuses a file."""
    try:
        directory.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryFile(dir=directory):
            pass
    except OSError as exc:
        return exc.strerror or str(exc)
    return None
