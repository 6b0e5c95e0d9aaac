"""The access log never carries a query string.

A client that puts a secret in the URL (``?api_key=...``) must not find it in the server's
logs: uvicorn's access log writes the request's full path, query included, so
:data:`REDACT_QUERY`, added to the ``uvicorn.access`` logger by
:func:`plotgate.service.app.create_app`, replaces every query with ``?[redacted]``. plotgate reads
nothing from query strings, so nothing of use is lost.
"""

import logging

__all__ = ["REDACT_QUERY", "RedactQuery"]


class RedactQuery(logging.Filter):
    """Replace the query string in uvicorn's access-log records with ``?[redacted]``.

    uvicorn logs ``'%s - "%s %s HTTP/%s" %d'`` with the arguments (client, method, full
    path, HTTP version, status); any other record passes unchanged.
    """

    def filter(self, record: logging.LogRecord) -> bool:
        args = record.args
        if isinstance(args, tuple) and len(args) >= 3 and isinstance(args[2], str):
            path, mark, _ = args[2].partition("?")
            if mark:
                record.args = (*args[:2], path + "?[redacted]", *args[3:])
        return True


REDACT_QUERY = RedactQuery()
"""The one filter instance, so adding it again (an app per test) adds nothing."""
