"""An episode's folder lock (`services.studies.evaluation.runner.episode_lock`): a second
attempt at an episode waits for the stack of a first attempt whose worker died, instead of
running a second stack into the same folder."""

from __future__ import annotations

import subprocess
import sys
import textwrap
from pathlib import Path

from services.studies.evaluation.runner import episode_lock

ROOT = Path(__file__).resolve().parents[3]


def test_a_second_attempt_waits_for_the_stack_a_dead_worker_left_running(tmp_path):
    marker = tmp_path / "first-stack-ended"
    # The "worker": takes the lock, starts a "launcher" that inherits the lock's descriptor and
    # runs on for a while, then dies at once without releasing anything.
    worker = textwrap.dedent(f"""
        import os, subprocess, sys
        from pathlib import Path
        from services.studies.evaluation.runner import episode_lock
        with episode_lock(Path({str(tmp_path)!r})) as fd:
            subprocess.Popen([sys.executable, "-c",
                              "import time; time.sleep(1.5); open({str(marker)!r}, 'w').write('x')"],
                             pass_fds=(fd,), start_new_session=True, stdout=subprocess.DEVNULL,
                             stderr=subprocess.DEVNULL)
            print("started", flush=True)
            os._exit(0)
    """)
    done = subprocess.run([sys.executable, "-c", worker], cwd=ROOT, capture_output=True, text=True, timeout=60)
    assert done.stdout.strip() == "started", done.stderr
    assert not marker.exists()
    with episode_lock(tmp_path):
        assert marker.exists(), "the second attempt got the lock while the first stack still ran"


def test_the_lock_is_free_again_after_a_finished_attempt(tmp_path):
    with episode_lock(tmp_path):
        pass
    with episode_lock(tmp_path):
        assert (tmp_path / ".episode.lock").exists()
