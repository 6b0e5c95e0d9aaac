"""How to install one of plotgate's extras where this copy of plotgate runs: from the clone
it was installed from in editable mode (``pip install -e``), or from a package index."""

import json
import sys
from importlib import metadata
from urllib.parse import unquote, urlparse

__all__ = ["install_hint"]


def _editable_source() -> str | None:
    """The folder this copy was installed from with ``pip install -e`` (PEP 610's
    ``direct_url.json``), or None for an install from an index or a wheel."""
    try:
        text = metadata.distribution("plotgate").read_text("direct_url.json")
    except metadata.PackageNotFoundError:
        return None
    if not text:
        return None
    direct = json.loads(text)
    if not direct.get("dir_info", {}).get("editable"):
        return None
    url = urlparse(direct.get("url", ""))
    return unquote(url.path) if url.scheme == "file" else None


def install_hint(extra: str) -> str:
    """The command that installs ``extra`` into the environment running now: ``pip install
    -e '<clone>[extra]'`` for an editable install (a name would be looked up on an index,
    not in the clone), else ``pip install 'plotgate[extra]'``; pip run by this
    interpreter."""
    pip = f"{sys.executable} -m pip install"
    source = _editable_source()
    if source is not None:
        return f'{pip} -e "{source}[{extra}]"'
    return f'{pip} "plotgate[{extra}]"'
