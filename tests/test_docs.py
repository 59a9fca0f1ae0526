"""The documentation runs: the API tour executes, the CLI reference is current; and the
code reads as the house writes it (its lint passes)."""

import re
import subprocess
import sys
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


def test_readme_snippet_runs_on_the_readme_sequence(tmp_path, monkeypatch):
    """The README's Python snippet, on a sequence made as the README's `hullcap synth` makes
    it (colour frames and backgrounds, no silhouettes), shortened to a few frames."""
    from hullcap._cli import main

    text = (DOCS.parent / "README.md").read_text()
    (block,) = re.findall(r"```python\n(.*?)```", text, re.S)
    monkeypatch.chdir(tmp_path)
    assert main(["synth", "SEQ", "--frames", "3", "--cameras", "6", "--subject", "short"]) == 0
    namespace: dict = {}
    exec(compile(block, "README.md", "exec"), namespace)
    assert (tmp_path / "OUT" / "joints.csv").is_file()
    assert len(namespace["masks"]) == 6 and namespace["fitted"].iterations > 0


def test_cli_reference_is_current(monkeypatch):
    from hullcap._cli import reference

    monkeypatch.setenv("COLUMNS", "100")
    assert (DOCS / "cli.md").read_text().rstrip() == reference().rstrip(), "run `make docs`"


ROOT = DOCS.parent.resolve()
CHECKED = ("README.md", "docs", "python", "crates", "tests", "benchmarks", "data", "Makefile", "pyproject.toml")
MD_REFERENCE = re.compile(r"(?<![\w./-])((?:\.\./)*[\w./-]*[\w-]+\.md)\b")


def _sources():
    for entry in CHECKED:
        path = ROOT / entry
        files = [path] if path.is_file() else path.rglob("*")
        for f in files:
            if f.is_file() and f.suffix in (".md", ".py", ".rs", ".pyi", ".json", ".toml", "") \
                    and "devset" not in f.parts:
                yield f


def test_every_markdown_file_the_repository_names_exists():
    """Code and docs cite only documents the repository holds: a reference resolves,
    inside the repository, from the citing file's folder, from docs/ or from the root."""
    missing = []
    for f in _sources():
        for ref in MD_REFERENCE.findall(f.read_text(errors="ignore")):
            name = ref.split("#")[0]
            found = [(base / name).resolve() for base in (f.parent, DOCS, ROOT)]
            if not any(p.is_file() and p.is_relative_to(ROOT) for p in found):
                missing.append(f"{f.relative_to(ROOT)}: {ref}")
    assert not missing, missing


def test_the_public_surface_is_hullcap_errors_and_export():
    """Every importable module but these three is private (its name starts with `_`), and
    every name the three export exists. `hullcap.data` holds the shipped files and the
    maintainers' scripts that rebuild them, not API."""
    import importlib
    import pkgutil

    import hullcap

    public = {"hullcap", "hullcap.errors", "hullcap.export"}
    found = {"hullcap"} | {m.name for m in pkgutil.walk_packages(hullcap.__path__, "hullcap.")
                           if not m.name.startswith("hullcap.data")}
    assert {m for m in found if not any(p.startswith("_") for p in m.split("."))} == public
    for name in public:
        module = importlib.import_module(name)
        missing = [n for n in module.__all__ if not hasattr(module, n)]
        assert not missing, (name, missing)


def test_the_python_code_passes_the_house_lint():
    """ruff with the rules and line length of pyproject.toml, over every Python file of the
    repository."""
    run = subprocess.run([sys.executable, "-m", "ruff", "check", "--no-cache", str(ROOT)], capture_output=True,
                         text=True)
    assert run.returncode == 0, run.stdout + run.stderr
