"""The checkout guard (`tests/checkout_guard.py`) on a real temporary git checkout."""

from __future__ import annotations

import subprocess

from tests import checkout_guard


def _git(repo, *args):
    subprocess.run(["git", *args], cwd=repo, check=True, capture_output=True)


def test_the_guard_names_what_a_run_created_changed_or_removed(tmp_path):
    _git(tmp_path, "init", "-q")
    (tmp_path / ".gitignore").write_text("/out/\n.venv/\n")
    (tmp_path / "tracked.txt").write_text("one\n")
    _git(tmp_path, "add", ".")
    _git(tmp_path, "-c", "user.email=t@t", "-c", "user.name=t", "commit", "-q", "-m", "init")
    (tmp_path / ".venv").mkdir()
    (tmp_path / ".venv" / "python").write_text("the run's own install")
    before = checkout_guard.snapshot(tmp_path)
    assert before == {} and checkout_guard.is_clean(before)

    (tmp_path / "tracked.txt").write_text("two\n")  # a tracked file rewritten
    (tmp_path / "out").mkdir()
    (tmp_path / "out" / "report.json").write_text("{}")  # written into an ignored directory
    (tmp_path / "stray.txt").write_text("x")  # an untracked file left behind
    (tmp_path / ".venv" / "more").write_text("the run's own: not counted")
    after = checkout_guard.snapshot(tmp_path)
    assert not checkout_guard.is_clean(after)
    assert checkout_guard.changes(before, after) == ["created: out/", "created: stray.txt", "changed: tracked.txt"]

    (tmp_path / "out" / "second.json").write_text("{}")  # a file added inside an ignored folder
    assert checkout_guard.changes(after, checkout_guard.snapshot(tmp_path)) == ["changed: out/"]


def test_a_directory_that_is_not_a_checkout_is_not_judged(tmp_path):
    assert checkout_guard.snapshot(tmp_path / "nowhere") is None
