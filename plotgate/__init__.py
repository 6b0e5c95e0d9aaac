"""plotgate: radar track initiation and target localization, every exchange recorded.

The distribution installs one import package, ``plotgate``, whose subpackages live in the
repository's top-level folders (``pyproject.toml`` maps them):

- :mod:`plotgate.core`: the estimation library (numpy, scipy and numba only);
- :mod:`plotgate.service`: the FastAPI service, its wire schemas and the MCAP recorder;
- :mod:`plotgate.clients`: the HTTP client, the ``plotgate`` command and the replay tools.
"""

from importlib import metadata

__all__ = ["__version__"]

try:
    __version__ = metadata.version("plotgate")
except metadata.PackageNotFoundError:  # a source tree that was never installed
    __version__ = "0+unknown"
