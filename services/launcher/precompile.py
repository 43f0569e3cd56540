"""Byte-compile the stack's own packages once before `handover-up` starts the services."""

from __future__ import annotations

import compileall
import importlib.util

#: The stack's own packages (an editable install is not byte-compiled by pip).
STACK_PACKAGES = ("bus_schema", "handover_model", "robot_sim", "services")


def precompile_stack() -> None:
    """Byte-compile the stack's packages once, before the services start: on a fresh checkout
    eight processes would otherwise each compile the same modules at once and starve the
    first episode of CPU. With up-to-date `.pyc` files this is a stat per file."""
    for name in STACK_PACKAGES:
        spec = importlib.util.find_spec(name)
        for location in (spec.submodule_search_locations or []) if spec else []:
            compileall.compile_dir(location, quiet=1, workers=1)
