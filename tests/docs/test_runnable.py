"""The README and the docs pages run as written.

Every ``sh`` and ``python`` block of the README and of ``docs/*.md`` runs, in page order, in
a new shell (``bash -e -o pipefail``, with the virtual environment's ``bin`` taken off
``PATH``, as a newcomer's new shell has it) in a scratch folder that holds a link to the
``.venv`` of this installation and a copy of ``docs/examples``; the pages' server,
``http://127.0.0.1:8000``, is a live ``plotgate serve`` on a free loopback port, recording
to the scratch folder's ``recordings/``. A block must exit 0, and print what the page's
``output`` block after it shows (``tests/support/markdown.py`` says how floats and ``...``
compare). A block marked ``<!-- not run: why -->`` is counted and listed, not run.
"""

import os
import re
import shutil
import subprocess
import sys
import time
from pathlib import Path

import pytest

import plotgate.service.registry  # noqa: F401 - compiles the kernels here, before the server and blocks load them
from tests.support.markdown import Block, blocks, documents, json_matches, links, text_matches
from tests.support.servers import serve

ROOT = Path(__file__).resolve().parents[2]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
PAGE_SERVER = "http://127.0.0.1:8000"
BLOCK_TIMEOUT_S = 300  # a hang, not a speed figure
LOCAL_OR_CITATION = ("http://127.0.0.1", "http://localhost", "https://doi.org/")
"""The links that may leave the repository: the service itself, and a paper's DOI."""


@pytest.fixture(scope="module")
def scratch(tmp_path_factory) -> Path:
    assert shutil.which("curl") and shutil.which("bash"), "the pages' commands need bash and curl"
    folder = tmp_path_factory.mktemp("newcomer")
    (folder / ".venv").symlink_to(sys.prefix)
    shutil.copytree(ROOT / "docs/examples", folder / "docs/examples")
    (folder / "docs/figures").mkdir()
    return folder


@pytest.fixture(scope="module")
def server(scratch) -> str:
    with serve(scratch / "recordings") as (_, url):
        yield url


def _new_shell_env() -> dict[str, str]:
    bin_dir = str(Path(sys.prefix) / "bin")
    env = {k: v for k, v in os.environ.items() if k != "VIRTUAL_ENV"}
    env["PATH"] = os.pathsep.join(p for p in env.get("PATH", "").split(os.pathsep) if p != bin_dir)
    return env


def _run(block: Block, url: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    code = block.code.replace(PAGE_SERVER, url)
    command = ["bash", "-e", "-o", "pipefail", "-c", code]
    if block.language == "python":
        command = [str(cwd / ".venv/bin/python"), "-c", code]
    return subprocess.run(
        command,
        cwd=cwd,
        env=_new_shell_env(),
        capture_output=True,
        text=True,
        timeout=BLOCK_TIMEOUT_S,
    )


def _mismatch(block: Block, printed: str) -> str | None:
    """What differs between the block's shown output and what it printed, or None."""
    assert block.output is not None
    shown = block.output.code
    if block.output.language == "json":
        try:
            differences = json_matches(documents(shown, shown=True), documents(printed, False))
        except ValueError as exc:
            return f"not the JSON shown ({exc}):\n{printed}"
        return "\n".join(differences) or None
    return None if text_matches(shown, printed) else f"shown:\n{shown}\nprinted:\n{printed}"


@pytest.mark.slow
@pytest.mark.parametrize("page", PAGES, ids=lambda p: str(p.relative_to(ROOT)))
def test_every_block_runs_and_prints_what_the_page_shows(page, server, scratch, docs_tally):
    failures = []
    for block in blocks(page):
        if not block.runnable:
            continue
        if block.not_run is not None:
            docs_tally["not run"].append(f"{block.where()}: {block.not_run}")
            continue
        started = time.monotonic()
        done = _run(block, server, scratch)
        docs_tally["run"].append(f"{block.where()} ({time.monotonic() - started:.1f} s)")
        if done.returncode != 0:
            failures.append(f"{block.where()}: exit {done.returncode}\n{done.stderr[-2000:]}")
        elif block.output is not None:
            docs_tally["compared"].append(block.where())
            if (mismatch := _mismatch(block, done.stdout)) is not None:
                failures.append(f"{block.where()}: {mismatch}")
    assert not failures, "\n\n".join(failures)


@pytest.mark.parametrize("page", PAGES, ids=lambda p: str(p.relative_to(ROOT)))
def test_links_stay_in_the_repository_and_resolve(page):
    broken = []
    for target in links(page):
        if target.startswith(LOCAL_OR_CITATION):
            continue
        path, _, anchor = target.partition("#")
        file = (page.parent / path).resolve() if path else page
        if "://" in target or not file.is_relative_to(ROOT) or not file.exists():
            broken.append(f"{target}: not a file of the repository")
        elif anchor and anchor not in _anchors(file):
            broken.append(f"{target}: no heading of {file.name} has that anchor")
    assert not broken, broken


def _anchors(page: Path) -> set[str]:
    """GitHub's anchors of the page's headings: lower case, punctuation dropped, spaces
    as hyphens."""
    return {
        re.sub(r"[^\w\- ]", "", line.lstrip("#").strip().lower()).replace(" ", "-")
        for line in page.read_text().split("\n")
        if line.startswith("#")
    }


@pytest.mark.parametrize("page", PAGES, ids=lambda p: str(p.relative_to(ROOT)))
def test_every_block_is_compared_or_says_why_not(page):
    """Every command of the docs is run and its output compared with what the page shows,
    or marked ``<!-- not run: why -->`` (issue 37: the shown and the real output differed)."""
    unchecked = [
        b.where() for b in blocks(page) if b.runnable and b.not_run is None and b.output is None
    ]
    assert not unchecked, f"runnable blocks without an output block: {unchecked}"


def test_a_stale_output_is_caught():
    """The README once showed a gating probability and its error estimate from an older
    quadrature; the comparison refuses them against today's answer."""
    stale = '{"conditional":false,"probability":0.8199273684131165,"error":6.523937279290237e-9}'
    today = '{"conditional":false,"probability":0.8199273688200057,"error":1.4088265332112826e-8}'
    differences = json_matches(documents(stale, shown=True), documents(today, shown=False))
    assert [d.split(":")[0] for d in differences] == ["[0].probability", "[0].error"]
    assert json_matches(documents(today, shown=True), documents(today, shown=False)) == []
