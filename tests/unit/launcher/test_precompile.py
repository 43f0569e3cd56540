"""The launcher byte-compiles the stack once before the services start."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

from services.launcher import precompile


def test_precompile_writes_the_bytecode_of_every_module_of_the_stack_packages(tmp_path, monkeypatch):
    pkg = tmp_path / "fakestack"
    (pkg / "sub").mkdir(parents=True)
    for rel in ("__init__.py", "a.py", "sub/__init__.py", "sub/b.py"):
        (pkg / rel).write_text("X = 1\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.setattr(precompile, "STACK_PACKAGES", ("fakestack", "no_such_package_here"))
    precompile.precompile_stack()
    for rel in ("__init__.py", "a.py", "sub/__init__.py", "sub/b.py"):
        assert Path(importlib.util.cache_from_source(str(pkg / rel))).exists(), rel
    sys.modules.pop("fakestack", None)
