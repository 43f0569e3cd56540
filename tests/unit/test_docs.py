"""The documentation: a README a newcomer reads in ten minutes, links that resolve, one source
for each sentence, and the quick start that CI runs.

- README.md has at most `README_MAX_LINES` lines;
- every relative link in README.md, CHANGELOG.md and docs/*.md points to a file that exists, and
  an anchor into a Markdown file names one of its headings (GitHub's slugs);
- no line of `MIN_REPEATED_CHARS` characters or more appears in two of those files (code blocks,
  tables' header and separator rows, and generated regions between `<!-- name:begin ... -->`
  and `<!-- name:end -->` markers do not count);
- the README holds the two quick-start command lines, the second exactly as `.ci/run` runs it.

Each checker is a plain function of paths, so the tests at the end can show it fail.
"""

import re
from collections import defaultdict
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
README_MAX_LINES = 400
MIN_REPEATED_CHARS = 80

_FENCE = re.compile(r"^\s*(```|~~~)")
_BEGIN = re.compile(r"<!--\s*([\w-]+):begin\b")
_END = re.compile(r"<!--\s*([\w-]+):end\b")
_INLINE_CODE = re.compile(r"(`+)(?:(?!\1).)+?\1")
_LINK = re.compile(r"\]\(\s*<?([^)\s>]+)>?(?:\s+\"[^\"]*\")?\s*\)")
_REF_LINK = re.compile(r"^\s*\[[^\]]+\]:\s*<?(\S+?)>?(?:\s+\"[^\"]*\")?\s*$")
_HEADING = re.compile(r"^ {0,3}(#{1,6})\s+(.*?)\s*#*\s*$")
_TABLE_SEPARATOR = re.compile(r"^\|?\s*:?-{3,}:?\s*(\|\s*:?-{3,}:?\s*)*\|?$")
_EXTERNAL = re.compile(r"^[a-zA-Z][a-zA-Z0-9+.-]*:")


def doc_files(root: Path = REPO) -> list[Path]:
    """The Markdown files these checks cover: README.md, CHANGELOG.md (when there) and docs/*.md."""
    files = [root / "README.md", root / "CHANGELOG.md", *sorted((root / "docs").glob("*.md"))]
    return [f for f in files if f.is_file()]


def prose_lines(text: str, generated: bool = False) -> list[tuple[int, str]]:
    """(line number, line) of every line outside fenced code blocks and, unless `generated`,
    outside generated regions (their marker lines are never included)."""
    out, fence, region = [], None, None
    for number, line in enumerate(text.splitlines(), 1):
        fence_match = _FENCE.match(line)
        if fence_match:
            if fence is None:
                fence = fence_match.group(1)
            elif fence_match.group(1) == fence:
                fence = None
            continue
        if fence is not None:
            continue
        if region is None:
            begin = _BEGIN.search(line)
            if begin:
                region = begin.group(1)
                continue
        else:
            end = _END.search(line)
            if end and end.group(1) == region:
                region = None
                continue
            if not generated:
                continue
        out.append((number, line))
    return out


def github_slug(heading: str) -> str:
    """The anchor GitHub gives a heading: links and inline markup reduced to their text, lower
    case, punctuation dropped, spaces to hyphens."""
    text = re.sub(r"!?\[([^\]]*)\]\([^)]*\)", r"\1", heading)
    text = re.sub(r"<[^>]+>", "", text)
    text = text.strip().lower()
    text = re.sub(r"[^\w\- ]", "", text)
    return text.replace(" ", "-")


def anchors(path: Path) -> set[str]:
    """Every anchor of a Markdown file: its headings' slugs (repeats get -1, -2, ... as on
    GitHub) and explicit `<a name=...>` / `id=...` anchors."""
    seen: dict[str, int] = defaultdict(int)
    found = set()
    text = path.read_text(encoding="utf-8")
    for _number, line in prose_lines(text, generated=True):
        heading = _HEADING.match(line)
        if heading:
            slug = github_slug(heading.group(2))
            found.add(slug if seen[slug] == 0 else f"{slug}-{seen[slug]}")
            seen[slug] += 1
    found.update(re.findall(r"<a\s+(?:name|id)=\"([^\"]+)\"", text))
    return found


def links(path: Path) -> list[tuple[int, str]]:
    """(line number, target) of every relative link of a Markdown file (inline, image and
    reference links; not in code)."""
    out = []
    for number, line in prose_lines(path.read_text(encoding="utf-8"), generated=True):
        line = _INLINE_CODE.sub("code", line)
        targets = _LINK.findall(line)
        ref = _REF_LINK.match(line)
        if ref:
            targets.append(ref.group(1))
        out.extend((number, t) for t in targets if not _EXTERNAL.match(t))
    return out


def broken_links(files: list[Path], root: Path = REPO) -> list[str]:
    """One line per link that points nowhere: a missing file, or an anchor that no heading of
    the Markdown file it points into has."""
    problems, cache = [], {}
    for path in files:
        for number, target in links(path):
            file_part, _, anchor = target.partition("#")
            dest = (path.parent / file_part).resolve() if file_part else path.resolve()
            where = f"{path.relative_to(root)}:{number}: ({target})"
            if not dest.exists():
                problems.append(f"{where}: no such file")
                continue
            if anchor and dest.suffix == ".md":
                if dest not in cache:
                    cache[dest] = anchors(dest)
                if anchor not in cache[dest]:
                    problems.append(f"{where}: no heading with the anchor #{anchor} in {dest.name}")
    return problems


def repeated_lines(files: list[Path], min_chars: int = MIN_REPEATED_CHARS,
                   root: Path = REPO) -> dict[str, list[str]]:
    """Lines of at least `min_chars` characters (stripped) found in two or more of `files`, with
    where each one is (`file:line`)."""
    where: dict[str, dict[Path, int]] = defaultdict(dict)
    for path in files:
        lines = prose_lines(path.read_text(encoding="utf-8"))
        for i, (number, line) in enumerate(lines):
            line = line.strip()
            following = lines[i + 1][1].strip() if i + 1 < len(lines) else ""
            if len(line) < min_chars or _TABLE_SEPARATOR.match(line):
                continue
            if line.startswith("|") and _TABLE_SEPARATOR.match(following):
                continue  # a table's header row: column names, not a sentence
            where[line].setdefault(path, number)
    return {line: [f"{p.relative_to(root)}:{n}" for p, n in places.items()]
            for line, places in where.items() if len(places) > 1}


def ci_test_command(ci_script: Path) -> str:
    """The line of `.ci/run` that sets up the venv and runs pytest."""
    for line in ci_script.read_text(encoding="utf-8").splitlines():
        if line.strip().startswith("python3.11 -m venv") and "pytest" in line:
            return line.strip()
    raise AssertionError(f"{ci_script}: no 'python3.11 -m venv ... pytest' line")


def quick_start_commands(ci_script: Path) -> tuple[str, str]:
    """The README's two quick-start lines: the main job (the same set-up, then handover-up) and
    the tests, exactly as CI runs them."""
    test_line = ci_test_command(ci_script)
    setup = test_line.rsplit(" && ", 1)[0]
    return f"{setup} && .venv/bin/handover-up", test_line


def missing_quick_start(readme: Path, ci_script: Path) -> list[str]:
    """The quick-start lines that are not a line of the README."""
    lines = {line.strip() for line in readme.read_text(encoding="utf-8").splitlines()}
    return [c for c in quick_start_commands(ci_script) if c not in lines]


def line_count(path: Path) -> int:
    """Lines of a text file."""
    return len(path.read_text(encoding="utf-8").splitlines())


# --- the repository ---------------------------------------------------------------------------

def test_readme_is_short():
    assert line_count(REPO / "README.md") <= README_MAX_LINES


def test_every_relative_link_resolves():
    assert broken_links(doc_files()) == []


def test_no_long_line_is_in_two_files():
    repeats = repeated_lines(doc_files())
    assert not repeats, "\n".join(f"{', '.join(w)}: {line[:100]}" for line, w in repeats.items())


def test_readme_holds_the_quick_start_that_ci_runs():
    assert missing_quick_start(REPO / "README.md", REPO / ".ci" / "run") == []


# --- the checkers fail when they should -------------------------------------------------------

def _tree(tmp_path: Path, files: dict[str, str]) -> Path:
    for name, text in files.items():
        (tmp_path / name).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / name).write_text(text, encoding="utf-8")
    return tmp_path


def test_broken_file_and_anchor_links_are_found(tmp_path):
    root = _tree(tmp_path, {
        "README.md": "# Top\n\nSee [a](docs/a.md#the-b-part-c), [gone](docs/gone.md), [x](docs/a.md#nope),\n"
                     "[here](#top), [self](#missing), ![img](docs/img/x.png), `[code](not/checked.md)`\n"
                     "[web](https://example.org/x.md), [made](docs/a.md#made-by-a-tool)\n\n"
                     "```\n[in code](nowhere.md)\n```\n",
        "docs/a.md": "# A\n\n## The `b` part: (c)\n\n[up](../README.md#top)\n\n<!-- t:begin -->\n"
                     "## Made by a tool\n\n[bad](generated.md)\n<!-- t:end -->\n",
    })
    problems = broken_links(doc_files(root), root)
    assert len(problems) == 5, problems
    assert any("generated.md" in p for p in problems)
    assert any("docs/gone.md" in p and "no such file" in p for p in problems)
    assert any("#nope" in p for p in problems)
    assert any("#missing" in p for p in problems)
    assert any("docs/img/x.png" in p for p in problems)


def test_slugs_follow_github():
    assert github_slug("`handover-bridge`: the robot bridge") == "handover-bridge-the-robot-bridge"
    assert github_slug("Planner: where to hand the object over (DJT, thesis §2.2–2.5)") == \
        "planner-where-to-hand-the-object-over-djt-thesis-2225"
    assert github_slug("The [linked](x.md) one") == "the-linked-one"


def test_repeated_headings_get_numbered_anchors(tmp_path):
    root = _tree(tmp_path, {"README.md": "# T\n\n## Tests\n\n## Tests\n"})
    assert {"tests", "tests-1"} <= anchors(root / "README.md")


def test_a_long_line_in_two_files_is_found_but_not_in_code_headers_or_generated_regions(tmp_path):
    long = "This sentence is long enough to count, because it has well over eighty characters in it."
    header = "| a table header long enough to count as a sentence, repeated in two files | x |"
    data = "| a table data row long enough to count as a sentence, repeated in two files | 1 |"
    root = _tree(tmp_path, {
        "README.md": f"# R\n\n{long}\n\n```\n{long}x\n```\n\n{header}\n|---|---|\n{data}\n",
        "docs/a.md": f"# A\n\n  {long}\n\n```\n{long}x\n```\n\n<!-- gen:begin (made by a tool) -->\n"
                     f"{data}\n<!-- gen:end -->\n\n{header}\n| :--- | ---: |\n",
        "CHANGELOG.md": f"# C\n\n| h | h |\n|---|---|\n{data}\n",
    })
    repeats = repeated_lines(doc_files(root), root=root)
    assert repeats == {long: ["README.md:3", "docs/a.md:3"], data: ["README.md:11", "CHANGELOG.md:5"]}


def test_the_quick_start_check_fails_without_the_ci_line(tmp_path):
    ci = "python3.11 -m venv .venv && .venv/bin/pip install -e . && .venv/bin/python -m pytest -m x"
    root = _tree(tmp_path, {
        ".ci/run": f"#!/bin/sh\nset -e\n{ci}\nexit $?\n",
        "good.md": f"```\n{ci.rsplit(' && ', 1)[0]} && .venv/bin/handover-up\n```\n\n```\n{ci}\n```\n",
        "bad.md": f"```\n{ci} -q\n```\n",
    })
    assert missing_quick_start(root / "good.md", root / ".ci/run") == []
    assert len(missing_quick_start(root / "bad.md", root / ".ci/run")) == 2
    with pytest.raises(AssertionError):
        ci_test_command(_tree(tmp_path, {"empty": "echo\n"}) / "empty")


def test_the_line_limit_counts_lines(tmp_path):
    path = _tree(tmp_path, {"README.md": "x\n" * (README_MAX_LINES + 1)}) / "README.md"
    assert line_count(path) > README_MAX_LINES
