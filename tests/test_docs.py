"""The documentation runs: the API tour executes, the CLI reference is current; and the
code reads as the house writes it (its lint passes)."""

import ast
import re
import subprocess
import sys
from pathlib import Path

import hullcap

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


def test_options_reference_is_current():
    from hullcap._take import options_page

    assert (DOCS / "options.md").read_text().rstrip() == options_page().rstrip(), "run `make docs`"


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


def _module_imports() -> dict[str, set[str]]:
    """Each module of the package (``_tracking``, ``export._bvh``) → the package's modules
    it imports when it is loaded (imports inside functions, made on demand, are left out)."""
    package = Path(hullcap.__file__).parent
    names = {".".join(p.relative_to(package).with_suffix("").parts).removesuffix("__init__").rstrip(".") or "hullcap"
             for p in package.rglob("*.py") if "data" not in p.parts}
    graph = {"_engine": set()}  # the Rust engine, imports nothing of ours
    names.add("_engine")
    for path in sorted(package.rglob("*.py")):
        if "data" in path.parts:
            continue
        name = ".".join(path.relative_to(package).with_suffix("").parts).removesuffix("__init__").rstrip(".")
        deps = set()
        for node in ast.parse(path.read_text()).body:
            modules = []
            if isinstance(node, ast.ImportFrom) and node.module and node.module.split(".")[0] == "hullcap":
                inner = node.module.removeprefix("hullcap").lstrip(".")
                subs = [f"{inner}.{a.name}".lstrip(".") for a in node.names]
                modules = [s if s in names else inner for s in subs]
            elif isinstance(node, ast.Import):
                modules = [a.name.removeprefix("hullcap").lstrip(".") for a in node.names
                           if a.name.split(".")[0] == "hullcap"]
            deps.update(m or "hullcap" for m in modules)
        graph[name or "hullcap"] = deps - {name or "hullcap"}
    return graph


def _import_map() -> str:
    """The package's modules in layers, each importing only from layers below it (a cycle
    fails), with what it imports."""
    graph, layer = _module_imports(), {}
    while len(layer) < len(graph):
        ready = [m for m in graph if m not in layer and all(d in layer for d in graph[m] if d in graph)]
        assert ready, f"the imports of {sorted(set(graph) - set(layer))} form a cycle"
        for m in ready:
            layer[m] = 1 + max((layer[d] for d in graph[m] if d in graph), default=-1)
    lines = []
    for k in range(max(layer.values()) + 1):
        for m in sorted(m for m in layer if layer[m] == k):
            imports = ", ".join(sorted(d for d in graph[m] if d in graph)) or "—"
            lines.append(f"{k:>2}  {m:<20} {imports}")
    return "\n".join(lines)


def test_the_module_map_of_design_md_is_the_code_and_has_no_cycle():
    doc = (DOCS / "design.md").read_text()
    block = doc.split("<!-- import map -->\n```text\n", 1)[1].split("```", 1)[0]
    assert block.rstrip() == _import_map(), "design.md's module map is out of date:\n" + _import_map()
