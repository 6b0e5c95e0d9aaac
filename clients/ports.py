"""Whether ``plotgate serve`` can listen where it is asked to, said before it starts.

uvicorn, given a port another process holds, logs "[Errno 98] error while attempting to
bind on address ... address already in use" and exits 3: no word of what to do. The check
here binds the address as uvicorn will (``SO_REUSEADDR`` set, so a port left in
TIME_WAIT by a server that just stopped is free, as uvicorn finds it) and lets it go at
once; the command then says what to change and exits 2, a usage error. Another process
may still take the port between the check and uvicorn's bind: uvicorn's own message then
stands.
"""

import errno
import socket

__all__ = ["listen_refused"]


def listen_refused(host: str, port: int) -> str | None:
    """Why ``host:port`` cannot be listened on, in one line naming the option to change;
    None when it can."""
    try:
        infos = socket.getaddrinfo(host, port, type=socket.SOCK_STREAM, flags=socket.AI_PASSIVE)
    except socket.gaierror as exc:
        return f"cannot listen on {host}: {exc.strerror}; give another address with --host"
    family, kind, proto, _, address = infos[0]
    try:
        with socket.socket(family, kind, proto) as probe:
            probe.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            probe.bind(address)
    except OSError as exc:
        where = f"[{host}]:{port}" if family == socket.AF_INET6 else f"{host}:{port}"
        if exc.errno == errno.EADDRINUSE:
            return f"{where} is already in use (another server?); choose another with --port"
        if exc.errno == errno.EACCES:
            return f"{where} needs privileges to listen on; choose a port from 1024 with --port"
        return f"cannot listen on {where}: {exc.strerror}; check --host and --port"
    return None
