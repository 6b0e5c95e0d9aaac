"""What built this process: versions and git commit, for the recordings' metadata."""

import json
import platform
import subprocess
from importlib import metadata
from pathlib import Path

import numpy
import scipy

from plotgate.service.config import Settings

__all__ = ["VERSION", "git_commit", "provenance"]

try:
    VERSION = metadata.version("plotgate")
except metadata.PackageNotFoundError:
    VERSION = "0+unknown"


def git_commit() -> str | None:
    """HEAD of the checkout this code runs from, or None outside a git work tree."""
    try:
        out = subprocess.run(
            ["git", "rev-parse", "HEAD"],
            cwd=Path(__file__).resolve().parent,
            capture_output=True,
            text=True,
            timeout=5,
            check=True,
        )
    except (OSError, subprocess.SubprocessError):
        return None
    return out.stdout.strip() or None


def provenance(settings: Settings) -> dict[str, str]:
    """String key/values for the ``plotgate`` metadata record of every MCAP file."""
    return {
        "plotgate_version": VERSION,
        "git_commit": settings.git_commit or git_commit() or "unknown",
        "python": platform.python_version(),
        "numpy": numpy.__version__,
        "scipy": scipy.__version__,
        "settings": json.dumps(settings.model_dump(mode="json"), sort_keys=True),
    }
