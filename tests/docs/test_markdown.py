"""The reading of pages' blocks and the comparison of outputs that test_runnable relies on."""

import pytest

from tests.support.markdown import blocks, documents, json_matches, text_matches

PAGE = """# A page

<!-- not run: starts a container -->
```sh
docker run plotgate
```

```sh
echo '{"x": 1.25}'
```

```json output
{"x": 1.3}
```

```json
{"shown": "only"}
```
"""


def test_blocks_carry_their_marker_and_their_output(tmp_path):
    page = tmp_path / "page.md"
    page.write_text(PAGE)
    docker, echo, output, shown = blocks(page)
    assert docker.not_run == "starts a container" and docker.runnable
    assert echo.not_run is None and echo.output is output and output.is_output
    assert not output.runnable and not shown.runnable and shown.output is None
    assert (echo.line, echo.code) == (8, "echo '{\"x\": 1.25}'\n")


def test_an_output_block_must_follow_a_runnable_one(tmp_path):
    page = tmp_path / "page.md"
    page.write_text("```json\n{}\n```\n\n```json output\n{}\n```\n")
    with pytest.raises(AssertionError, match="must follow a runnable block"):
        blocks(page)


@pytest.mark.parametrize(
    ("shown", "printed", "ok"),
    [
        ("1.3", "1.26", True),  # within half a unit of the last digit shown
        ("1.3", "1.36", False),
        ("0.8199273688200057", "0.8199273688200058", True),  # full digits: 1e-12 relative
        ("0.8199273684131165", "0.8199273688200057", False),
        ("1e-12", "1.4e-12", True),
        ("3", "3", True),
        ("3", "3.2", False),  # an integer shown is exact
        ('"..."', '{"any": [1]}', True),
        ("true", "1", False),
        ("[1.0, 2.0]", "[1.0]", False),
    ],
)
def test_numbers_match_to_the_digits_shown(shown, printed, ok):
    differences = json_matches(documents(shown, shown=True), documents(printed, shown=False))
    assert (differences == []) is ok, differences


def test_text_matches_with_ellipses():
    printed = "a.mcap: complete\n3 exchanges: 3 compared\n3 compared: 3 unchanged, 0 changed\n"
    assert text_matches("...\n... compared: ... unchanged, 0 changed\n", printed)
    assert not text_matches("...\n... compared: ... unchanged, 1 changed\n", printed)
    assert text_matches("a.mcap: complete\n...\n", printed)
    assert not text_matches("b.mcap: complete\n...\n", printed)
