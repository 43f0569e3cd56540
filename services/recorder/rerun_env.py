"""Environment for Rerun's native library, set before the recorder's first ``import rerun``.

- ``MIMALLOC_PURGE_DELAY=0``: Rerun's native code allocates with mimalloc, which by default
  keeps freed pages for reuse. The default arm's meshes (~30 MB) pass through the SDK once (encoded,
  compressed, written; with ``robot_model = "primitives"`` the URDF loader still reads them
  before they are dropped) and then stayed resident: ~90 MB RSS measured. With a purge delay of
  0 ms mimalloc returns freed pages at once: the URDF's lasting cost falls to ~13 MB.
  (Measured with the earlier one-entity-per-number recorder: ~12 % of its write throughput.)
- ``RUST_LOG``: the recorder streams its file without Rerun's footer on purpose and adds the
  footer when it closes the file (see `writer`, `finalise`); Rerun's file sink warns about the
  missing footer once at start-up. Silenced for that one module only; every other Rerun warning
  still shows.

mimalloc and Rerun's logger read these when the library loads, i.e. at the first
``import rerun`` of the process, so this module must be imported before that. Values already in
the environment win. Importing it after Rerun is harmless (no effect).
"""

from __future__ import annotations

import os

#: Variables and the values the recorder uses when they are not set already.
RERUN_ENV: dict[str, str] = {
    "MIMALLOC_PURGE_DELAY": "0",
    "RUST_LOG": "warn,re_log_encoding::rrd::file_sink=error",
}

for _name, _value in RERUN_ENV.items():
    os.environ.setdefault(_name, _value)
