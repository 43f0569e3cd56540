"""Checks of the paths a command will write, made before anything starts, and new private files."""

from __future__ import annotations

import os
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


def write_new_file(path: Path, data: bytes, private: bool) -> None:
    """Write `data` to a new file (never an existing one, nor through a symbolic link), readable
    by its owner only when `private` (mode 600, else 644), whatever the umask."""
    fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW, 0o600 if private else 0o644)
    with os.fdopen(fd, "wb") as out:
        out.write(data)
