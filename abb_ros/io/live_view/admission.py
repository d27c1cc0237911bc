"""Which browser pages the live view admits: the ``Origin`` of a WebSocket handshake."""

from __future__ import annotations

import fnmatch

DEFAULT_ALLOWED_ORIGINS = ('https://app.foxglove.dev', 'file://', 'http://localhost',
                           'http://localhost:*', 'http://127.0.0.1', 'http://127.0.0.1:*',
                           'http://[[]::1]', 'http://[[]::1]:*')
"""Browser origins admitted by default (shell patterns; ``[[]`` is a literal ``[``)."""


def origin_allowed(origin: str, allowed) -> bool:
    """Whether browser ``origin`` matches one of the shell patterns ``allowed``."""
    return any(fnmatch.fnmatchcase(origin.lower(), pattern.lower()) for pattern in allowed)
