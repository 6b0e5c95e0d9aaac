"""The tally of documentation blocks run and not run, printed after the tests."""

import pytest

TALLY = pytest.StashKey[dict[str, list[str]]]()


@pytest.fixture(scope="session")
def docs_tally(request) -> dict[str, list[str]]:
    """Lists of blocks (``page:line``) by what became of them: run (with its seconds),
    compared, not run (with why)."""
    return request.config.stash.setdefault(TALLY, {"run": [], "compared": [], "not run": []})


def pytest_terminal_summary(terminalreporter, config):
    tally = config.stash.get(TALLY, None)
    if tally is None:
        return
    terminalreporter.write_line(
        f"documentation: {len(tally['run'])} blocks run, {len(tally['compared'])} of them "
        f"compared with their output; {len(tally['not run'])} marked not run:"
    )
    for line in tally["not run"]:
        terminalreporter.write_line(f"  {line}")
    terminalreporter.write_line("blocks run: " + ", ".join(tally["run"]))
