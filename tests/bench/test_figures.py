"""Every committed figure is drawn by ``bench/figures.py`` from the code as it is: each PNG's
stamp is the hash of what draws it now (no drawing here, so this is quick)."""

import struct
import zlib

import pytest

from bench.figures import FIGURES, FOLDER, KEY, Recipe, source_hash, stale, stamp, stamp_of


def test_every_committed_figure_has_a_recipe():
    committed = {p.name for p in FOLDER.glob("*.png")}
    assert committed == {r.file for r in FIGURES.values()}
    assert all(name + ".png" == r.file for name, r in FIGURES.items())


@pytest.mark.parametrize("name", sorted(FIGURES))
def test_the_committed_figure_is_as_new_as_what_draws_it(name):
    recipe = FIGURES[name]
    assert stamp_of(FOLDER / recipe.file) == source_hash(recipe), (
        f"docs/figures/{recipe.file} is older than {', '.join(recipe.sources)} or its inputs: "
        f"python bench/figures.py --only {name}"
    )


def _png(*chunks: tuple[bytes, bytes]) -> bytes:
    out = b"\x89PNG\r\n\x1a\n"
    for kind, body in chunks:
        out += struct.pack(">I", len(body)) + kind + body
        out += struct.pack(">I", zlib.crc32(kind + body))
    return out


IHDR = (b"IHDR", struct.pack(">IIBBBBB", 1, 1, 8, 0, 0, 0, 0))
IDAT = (b"IDAT", zlib.compress(b"\0\0"))


def test_a_stamp_replaces_the_last_and_keeps_every_chunk(tmp_path):
    png = tmp_path / "f.png"
    png.write_bytes(_png(IHDR, (b"tEXt", b"Software\0matplotlib"), IDAT, (b"IEND", b"")))
    assert stamp_of(png) is None
    stamp(png, "abc")
    stamp(png, "def")
    data = png.read_bytes()
    assert stamp_of(png) == "def" and data.count(KEY.encode()) == 1
    assert data.index(b"IHDR") < data.index(KEY.encode()) < data.index(b"IDAT")
    assert b"Software\0matplotlib" in data and data.endswith(_png((b"IEND", b""))[8:])


def test_the_hash_follows_the_sources_and_the_inputs(tmp_path):
    (tmp_path / "draw.py").write_text("x = 1\n")
    recipe = Recipe("f.png", ("draw.py",), lambda out: None, {"seed": 1})
    before = source_hash(recipe, tmp_path)
    assert source_hash(Recipe("f.png", ("draw.py",), print, {"seed": 2}), tmp_path) != before
    (tmp_path / "draw.py").write_text("x = 2\n")
    assert source_hash(recipe, tmp_path) != before


def test_stale_names_a_missing_or_unstamped_figure(tmp_path):
    assert stale(tmp_path) == list(FIGURES)
    png = tmp_path / FIGURES["fig2_ring"].file
    png.write_bytes(_png(IHDR, IDAT, (b"IEND", b"")))
    stamp(png, "not the hash")
    assert "fig2_ring" in stale(tmp_path)
    stamp(png, source_hash(FIGURES["fig2_ring"]))
    assert "fig2_ring" not in stale(tmp_path)
    png.write_bytes(b"\x89PNG\r\n\x1a\n\x00\x00\xff\xffIHDR")  # cut short
    assert "fig2_ring" in stale(tmp_path)


def test_a_damaged_png_is_refused(tmp_path):
    bad = tmp_path / "bad.png"
    bad.write_bytes(b"GIF89a")
    with pytest.raises(ValueError, match="not a PNG"):
        stamp_of(bad)
    bad.write_bytes(_png(IHDR)[:-6])
    with pytest.raises(ValueError, match="past the end"):
        stamp_of(bad)
