"""`python -m tests.faults.readme_matrix`: its command line rewrites nothing on --help or a bad
argument, and the page it rewrites has its markers."""

import pytest

from tests.faults import readme_matrix


def test_help_prints_the_usage_and_rewrites_nothing(capsys):
    page = readme_matrix.REPO / readme_matrix.DOC
    before = page.read_bytes()
    with pytest.raises(SystemExit) as done:
        readme_matrix.main(["--help"])
    assert done.value.code == 0
    assert "docs/faults.md" in capsys.readouterr().out
    assert page.read_bytes() == before


@pytest.mark.parametrize("argv", [["--bogus"], ["README.md"]])
def test_a_bad_argument_is_one_line_and_exit_2(capsys, argv):
    page = readme_matrix.REPO / readme_matrix.DOC
    before = page.read_bytes()
    with pytest.raises(SystemExit) as done:
        readme_matrix.main(argv)
    assert done.value.code == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "error:" in err
    assert page.read_bytes() == before


def test_the_page_holds_one_region_between_its_markers():
    text = (readme_matrix.REPO / readme_matrix.DOC).read_text(encoding="utf-8")
    assert text.count(readme_matrix.BEGIN) == 1 and text.count(readme_matrix.END) == 1
    region = text[text.index(readme_matrix.BEGIN):text.index(readme_matrix.END)]
    assert readme_matrix.SECTION_DONE in region or readme_matrix.SECTION_IN_PROGRESS in region
