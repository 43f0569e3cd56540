"""The test suite must leave the checkout as it found it (issue 19: tests write only to
temporary directories).

`snapshot(repo)` lists every path git sees as changed, untracked or ignored under the checkout,
with a fingerprint of its content, except the install and cache directories the run itself
needs (`.venv/`, `__pycache__/`, `.pytest_cache/`, `*.egg-info/`). `changes(before, after)`
names what a run created, changed or removed. `tests/conftest.py` takes a snapshot when the
session starts on a clean checkout (as in CI) and fails the run if the suite changed it.
"""

from __future__ import annotations

import hashlib
import subprocess
from pathlib import Path

#: Path parts the run itself writes (the venv, byte code, tool caches, the editable install).
_OWN = (".venv", "__pycache__", ".pytest_cache", ".mypy_cache", ".ruff_cache")


def _ours(path: str) -> bool:
    parts = Path(path).parts
    return any(p in _OWN or p.endswith(".egg-info") for p in parts)


def _fingerprint(path: Path) -> str:
    try:
        if path.is_dir():  # an ignored folder, listed whole: its files' count and newest change
            stamps = [f.stat().st_mtime_ns for f in path.rglob("*") if f.is_file()]
            return f"dir:{len(stamps)}:{max(stamps, default=0)}"
        stat = path.stat()
        with open(path, "rb") as f:
            return f"{stat.st_size}:{hashlib.blake2b(f.read(1 << 20), digest_size=8).hexdigest()}"
    except OSError:
        return "gone"


def snapshot(repo: Path) -> dict[str, str] | None:
    """{path: status and content fingerprint} of every changed, untracked or ignored path
    under `repo` but the run's own; None when `repo` is not a git checkout."""
    try:
        out = subprocess.run(["git", "status", "--porcelain=v1", "-z", "--ignored=matching",
                              "--untracked-files=all"],
                             cwd=repo, capture_output=True, check=True, timeout=60).stdout
    except (OSError, subprocess.SubprocessError):
        return None
    entries: dict[str, str] = {}
    for record in out.decode("utf-8", "replace").split("\0"):
        if len(record) < 4:
            continue
        status, path = record[:2], record[3:]
        if not _ours(path):
            entries[path] = f"{status}:{_fingerprint(repo / path)}"
    return entries


def is_clean(entries: dict[str, str]) -> bool:
    """No tracked change and no untracked file (ignored files aside)."""
    return all(v.startswith("!!") for v in entries.values())


def changes(before: dict[str, str], after: dict[str, str]) -> list[str]:
    """What the run changed: one line per path created, changed or removed."""
    lines = []
    for path in sorted(set(before) | set(after)):
        if path not in before:
            new = after[path].startswith(("??", "!!"))
            lines.append(f"{'created' if new else 'changed'}: {path}")
        elif path not in after:
            lines.append(f"restored or removed: {path}")
        elif before[path] != after[path]:
            lines.append(f"changed: {path}")
    return lines
