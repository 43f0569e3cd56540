"""Keep freed memory in the process: no page faults and no address-space locks per frame.

glibc returns freed memory to the kernel as soon as the top of the heap has more than
128 kB free, and serves every block over 128 kB (a 320×240 depth image is 150 kB; its float
copies are 300–600 kB) with its own `mmap`. A service that makes such temporaries at 30 or
100 Hz then maps, faults in (a fresh zero page per 4 kB) and unmaps them frame after frame:
the idle tracker took about 4 700 page faults a second. Each map, unmap and heap trim takes
the process's address-space lock for writing; on a busy machine, while the thread holding it
waits for a CPU, every other thread of the process that touches memory (the heartbeat
thread, Zenoh's worker) sleeps in the kernel behind it, a silence that no run-queue figure
shows. Seen with `/proc/PID/task/*/wchan` during a 124 ms heartbeat gap beside two CPU hogs:
the main thread in ``vma_prepare`` and Zenoh's worker in ``do_mprotect_pkey``, both in D state.

`keep_freed_memory` sets glibc's thresholds (`mallopt`) so that blocks up to
`MMAP_THRESHOLD_BYTES` come from the heap and the heap is trimmed only past
`TRIM_THRESHOLD_BYTES`: a frame's temporaries reuse the pages of the previous frame. The
price is resident memory that stays at its high-water mark (a few MB per service; the
memory benchmark checks each service stays within DESIGN's 300 MB). On a C library without
`mallopt` (not glibc) it does nothing and says so in its return value.
"""

from __future__ import annotations

import ctypes
import ctypes.util

#: `mallopt` parameters (glibc's malloc.h).
_M_TRIM_THRESHOLD = -1
_M_TOP_PAD = -2
_M_MMAP_THRESHOLD = -3

#: Blocks up to this size come from the heap (glibc's default: 128 kB, then adaptive).
MMAP_THRESHOLD_BYTES = 8 << 20
#: Free memory at the top of the heap kept before any is given back (default 128 kB).
TRIM_THRESHOLD_BYTES = 64 << 20
#: Extra memory requested whenever the heap grows, so that it grows rarely (default 128 kB).
TOP_PAD_BYTES = 4 << 20


def keep_freed_memory() -> bool:
    """Apply the thresholds above to this process's allocator; True when glibc took them."""
    name = ctypes.util.find_library("c")
    try:
        libc = ctypes.CDLL(name)
        mallopt = libc.mallopt
    except (OSError, AttributeError, TypeError):
        return False
    mallopt.argtypes = (ctypes.c_int, ctypes.c_int)
    mallopt.restype = ctypes.c_int
    return all(mallopt(param, value) == 1 for param, value in (
        (_M_MMAP_THRESHOLD, MMAP_THRESHOLD_BYTES),
        (_M_TRIM_THRESHOLD, TRIM_THRESHOLD_BYTES),
        (_M_TOP_PAD, TOP_PAD_BYTES),
    ))
