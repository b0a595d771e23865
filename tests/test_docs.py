"""The documentation's links hold: README.md and docs/*.md point at files that exist.

Every relative Markdown link or image (``[text](path)``, ``[text](path#anchor)``) must name an
existing file or directory, and an anchor into a Markdown file must be one of its headings (as
GitHub makes them: lower case, punctuation dropped, spaces as hyphens). Every Python file the docs
name under scripts/, benchmarks/, research/, tests/, jobs/ or rap/ (in a command, ``python -m``
included, or in prose) must exist (a path with a placeholder such as ``test_NAME.py`` aside), and so must every dotted ``rap.`` name (a module, or a name a module or package defines),
so a moved script or module shows here. README.md
stays short: at most ``README_MAX_LINES`` lines, the rest lives in docs/ by topic. Reads text
only; nothing is run.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
README_MAX_LINES = 150

_LINK = re.compile(r"!?\[[^\]]*\]\(([^)\s]+)(?:\s+\"[^\"]*\")?\)")
_SCRIPT = re.compile(r"(?<![\w./-])((?:scripts|benchmarks|research|tests|jobs|rap)/[\w./-]*\.py)\b")
_RUN_MODULE = re.compile(r"\bpython3?\s+-m\s+((?:scripts|benchmarks|research|tests|jobs)(?:\.\w+)+)")
_MODULE = re.compile(r"(?<![\w./-])rap(?:\.[A-Za-z_]\w*)+")
_FENCE = re.compile(r"^(```|~~~)")
_TEMPLATE = re.compile(r"(?<![a-z0-9])[A-Z][A-Z0-9]*(?![a-z0-9])")  # a placeholder: test_NAME.py


def _prose(text: str) -> str:
    """``text`` without its fenced code blocks (links there are examples, not links)."""
    out, fenced = [], False
    for line in text.splitlines():
        if _FENCE.match(line.strip()):
            fenced = not fenced
            continue
        if not fenced:
            out.append(line)
    return "\n".join(out)


def slug(heading: str) -> str:
    """GitHub's anchor of a heading's text."""
    text = re.sub(r"`|\*\*|__", "", heading.strip().lower())
    text = re.sub(r"[^\w\- ]", "", text)
    return text.replace(" ", "-")


def anchors(path: Path) -> set[str]:
    """The anchors of a Markdown file's headings (repeated headings get -1, -2, ...)."""
    seen: dict[str, int] = {}
    out = set()
    for line in _prose(path.read_text(encoding="utf-8")).splitlines():
        m = re.match(r"^#{1,6}\s+(.*?)\s*#*\s*$", line)
        if not m:
            continue
        base = slug(m.group(1))
        n = seen.get(base, 0)
        seen[base] = n + 1
        out.add(base if n == 0 else f"{base}-{n}")
    return out


def links(text: str) -> list[str]:
    """The relative link targets of Markdown ``text`` outside code (http:, mailto: ... skipped)."""
    prose = re.sub(r"`[^`\n]*`", "", _prose(text))
    return [t for t in _LINK.findall(prose) if not re.match(r"^[a-z][a-z0-9+.-]*:", t)]


def test_slug_follows_github() -> None:
    assert slug("RAP's decision rule") == "raps-decision-rule"
    assert slug("Sixteen held-out assemblies (hold-out models)") == \
        "sixteen-held-out-assemblies-hold-out-models"
    assert slug("`search`'s options") == "searchs-options"
    assert slug("Planning: where `rap-farm plan` runs, and the service") == \
        "planning-where-rap-farm-plan-runs-and-the-service"


def test_links_parse() -> None:
    text = ("[a](docs/A.md) ![p](x.png) [b](B.md#sec) [c](https://example.org) `[d](e.md)`\n"
            "```\n[f](g.md)\n```\n[h](#local)")
    assert links(text) == ["docs/A.md", "x.png", "B.md#sec", "#local"]
    assert _TEMPLATE.search("tests/plan/test_NAME.py") and _TEMPLATE.search("families/NAME.py")
    assert not _TEMPLATE.search("rap/model/network/cnn.py") and not _TEMPLATE.search("tests/test_cli.py")


@pytest.mark.parametrize("doc", DOCS, ids=lambda p: str(p.relative_to(ROOT)))
def test_relative_links_resolve(doc: Path) -> None:
    broken = []
    for target in links(doc.read_text(encoding="utf-8")):
        file, _, anchor = target.partition("#")
        dest = (doc.parent / file).resolve() if file else doc
        if not dest.exists():
            broken.append(f"{target}: no such file")
        elif anchor and dest.suffix == ".md" and anchor not in anchors(dest):
            broken.append(f"{target}: no heading with that anchor in {dest.name}")
    assert not broken, f"{doc.relative_to(ROOT)}: " + "; ".join(broken)


@pytest.mark.parametrize("doc", DOCS, ids=lambda p: str(p.relative_to(ROOT)))
def test_named_python_files_exist(doc: Path) -> None:
    text = doc.read_text(encoding="utf-8")
    named = set(_SCRIPT.findall(text))
    named |= {m.replace(".", "/") + ".py" for m in _RUN_MODULE.findall(text)}
    missing = sorted(p for p in named if not (ROOT / p).is_file() and not _TEMPLATE.search(p))
    assert not missing, f"{doc.relative_to(ROOT)} names Python files that do not exist: {missing}"


def module_exists(name: str) -> bool:
    """Whether the dotted ``name`` is a module of rap/ or a name defined in one (``rap.x.NAME``)."""
    path = ROOT / "rap"
    for part in name.split(".")[1:]:
        if (path / part).is_dir():
            path = path / part
        elif (path / f"{part}.py").is_file():
            return True  # what follows is an attribute of the module
        else:
            init = path / "__init__.py"  # a name the package defines, imports or exports
            defined = rf"(?:def|class)\s+{part}\b|^{part}\s*[:=]|import\b.*\b{part}\b|[\'\"]{part}[\'\"]"
            return init.is_file() and re.search(defined, init.read_text("utf-8"), re.M) is not None
    return True


def test_module_exists() -> None:
    assert module_exists("rap.geometry.ndbg") and module_exists("rap.dataset.SCHEMA")
    assert module_exists("rap.geometry.families.generate")
    assert not module_exists("rap.plan.no_such_module")


@pytest.mark.parametrize("doc", DOCS, ids=lambda p: str(p.relative_to(ROOT)))
def test_named_modules_exist(doc: Path) -> None:
    missing = sorted({m for m in _MODULE.findall(doc.read_text(encoding="utf-8"))
                      if not module_exists(m)})
    assert not missing, f"{doc.relative_to(ROOT)} names rap modules that do not exist: {missing}"


def test_readme_is_short() -> None:
    n = len((ROOT / "README.md").read_text(encoding="utf-8").splitlines())
    assert n <= README_MAX_LINES, f"README.md has {n} lines (at most {README_MAX_LINES})"


def test_readme_keeps_the_ci_commands() -> None:
    """.ci/run installs and tests as the README tells a newcomer to: the same two commands."""
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    ci = (ROOT / ".ci" / "run").read_text(encoding="utf-8")
    for command in ("bash scripts/install.sh --test", "python -m pytest -q"):
        assert command in ci
        assert f"&& {command}" in readme or f"{command} &&" in readme
