"""The distribution: one import package, plotgate, with every folder's package inside it,
its typing marker and licence; and the version it reports."""

import subprocess
import sys
import zipfile
from importlib import metadata
from pathlib import Path

import plotgate
from plotgate.clients.cli import main

ROOT = Path(__file__).resolve().parents[1]


def test_the_wheel_installs_one_top_level_package(tmp_path):
    subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "--no-deps", "-q", "-w", str(tmp_path), str(ROOT)],
        check=True,
        capture_output=True,
    )
    [wheel] = tmp_path.glob("plotgate-*.whl")
    names = zipfile.ZipFile(wheel).namelist()
    top = {n.split("/")[0] for n in names if not n.split("/")[0].endswith(".dist-info")}
    assert top == {"plotgate"}
    folders = {
        p.parent.relative_to(ROOT)
        for layer in ("core", "service", "clients")
        for p in (ROOT / layer).rglob("__init__.py")
    }
    packaged = {Path(*Path(n).parts[1:]).parent for n in names if n.endswith("/__init__.py")}
    assert folders <= packaged  # every package folder of the tree is in the wheel
    assert "plotgate/py.typed" in names
    assert any(n.endswith(".dist-info/licenses/LICENSE") for n in names)


def test_the_version_comes_from_the_distribution(capsys):
    assert plotgate.__version__ == metadata.version("plotgate")
    try:
        main(["--version"])
    except SystemExit as exc:
        assert exc.code == 0
    assert capsys.readouterr().out.strip() == f"plotgate {plotgate.__version__}"
