"""``plotgate serve``'s listeners checked against the one authentication policy
(:mod:`plotgate.service.access`) before anything binds: the API's ``--host`` and the live
view's ``--foxglove-host``. With no key set, an address other than loopback is refused
(one line, exit 2) unless ``--allow-unauthenticated`` is given, which warns instead."""

import argparse
import sys
from typing import Any

__all__ = ["add_arguments", "overrides", "refused"]


def add_arguments(serve: argparse.ArgumentParser) -> None:
    """``serve --allow-unauthenticated``."""
    serve.add_argument(
        "--allow-unauthenticated",
        action="store_const",
        const=True,
        help="let the API or the live view listen on an address other than loopback with "
        "no key set (PLOTGATE_ALLOW_UNAUTHENTICATED; warns); refused otherwise",
    )


def overrides(args: argparse.Namespace) -> dict[str, Any]:
    """The environment ``--allow-unauthenticated`` sets."""
    return {"PLOTGATE_ALLOW_UNAUTHENTICATED": args.allow_unauthenticated}


def refused(settings: Any) -> bool:
    """Say on stderr why ``settings``' listeners may not bind (True), or warn about the
    ones allowed without a key (False)."""
    from plotgate.service.access import Keys, binding_refusal

    keys = Keys.from_settings(settings)
    listeners = [("the API", settings.host)]
    if settings.foxglove_port is not None:
        listeners.append(("the live view", settings.foxglove_host))
    for listener, host in listeners:
        refusal, warning = binding_refusal(listener, host, keys, settings.allow_unauthenticated)
        if refusal is not None:
            print(f"plotgate serve: {refusal}", file=sys.stderr)
            return True
        if warning is not None:
            print(f"plotgate serve: warning: {warning}", file=sys.stderr)
    return False
