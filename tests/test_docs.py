"""The documentation runs: the API tour executes, the CLI reference is current."""

import re
from pathlib import Path

DOCS = Path(__file__).resolve().parent.parent / "docs"


def test_api_tour_runs(tmp_path, monkeypatch):
    text = (DOCS / "api_tour.md").read_text()
    blocks = re.findall(r"```python\n(.*?)```", text, re.S)
    assert len(blocks) >= 5
    monkeypatch.chdir(tmp_path)
    namespace: dict = {}
    for i, block in enumerate(blocks):
        exec(compile(block, f"api_tour.md block {i + 1}", "exec"), namespace)
    assert (tmp_path / "take1_result" / "overlay" / "cam0.mp4").is_file()
    assert (tmp_path / "subject_model" / "links.json").is_file()


def test_cli_reference_is_current(monkeypatch):
    from hullcap.cli import reference

    monkeypatch.setenv("COLUMNS", "100")
    assert (DOCS / "cli.md").read_text().rstrip() == reference().rstrip(), "run `make docs`"
