"""Which handshakes the live view admits: the browser page's ``Origin``, and the ``Host`` asked.

Both are read as URLs (:func:`urllib.parse.urlsplit`: scheme, host name, port), never as
strings with a prefix: ``http://localhost:8080.evil.com`` is the host ``localhost`` with a port
that is no number, refused, not a page of ``localhost``.

Origin: a browser sends the page's origin, ``scheme://host[:port]``; it is admitted when a
pattern of ``allowed`` matches its scheme, host and port, each as a shell pattern of its own
(``http://localhost:*``: any port of localhost; no port in the pattern: the scheme's default
port only), or the pattern is ``*`` (any). A pattern that is no URL (``null``) is matched
against the whole origin.

Host (DNS rebinding): a page of ``http://rebind.evil.example`` whose name the attacker's DNS
points at 127.0.0.1 reaches a server on loopback as a page of that name, and its browser
sends ``Host: rebind.evil.example``. A server that listens on loopback only takes a ``Host``
that names loopback: ``localhost`` (or a name under ``.localhost``), an address of
127.0.0.0/8 or ``[::1]``, with an optional port.
"""

from __future__ import annotations

import fnmatch
import ipaddress
import re
from urllib.parse import urlsplit

__all__ = ['DEFAULT_ALLOWED_ORIGINS', 'DEFAULT_HOST', 'DEFAULT_PORT', 'LOOPBACK_HOSTS',
           'host_problem', 'is_loopback', 'origin_allowed']

DEFAULT_ALLOWED_ORIGINS = ('https://app.foxglove.dev', 'file://', 'http://localhost',
                           'http://localhost:*', 'http://127.0.0.1', 'http://127.0.0.1:*',
                           'http://[::1]', 'http://[::1]:*')
"""Browser origins admitted by default (``scheme://host[:port]``, each part a shell pattern)."""

LOOPBACK_HOSTS = 'localhost, 127.0.0.1 or [::1], with an optional port'
"""What a ``Host`` header may name when the server listens on loopback (for messages)."""

DEFAULT_HOST = '127.0.0.1'
"""The server listens on loopback unless told otherwise: it has no authentication."""
DEFAULT_PORT = 8765
"""The Foxglove WebSocket port the apps propose (and foxglove_bridge uses)."""

_DEFAULT_PORTS = {'http': 80, 'https': 443, 'ws': 80, 'wss': 443}
_PATTERN = re.compile(r'^(?P<scheme>[^:/]+)://(?P<host>\[[^/]*\]|[^:/]*)(?::(?P<port>[^/]*))?/?$')
_HOST_NAME = re.compile(r'^[a-z0-9_.-]*$')


def _origin_parts(origin: str):
    """Return (scheme, host, port) of a browser origin; None for one that is not a URL origin.

    ``port`` is the explicit port or the scheme's default (None for neither); a host is
    lowercase, an IPv6 address without its brackets.
    """
    try:
        url = urlsplit(origin.strip())
        port = url.port
    except ValueError:   # a port that is not a number in [0, 65535], a bad IPv6 literal
        return None
    if (not url.scheme or url.path not in ('', '/') or url.query or url.fragment
            or url.username is not None or url.password is not None
            or '@' in url.netloc):
        return None
    host = (url.hostname or '').lower()
    if not (_HOST_NAME.match(host) or _is_address(host)):
        return None
    return url.scheme.lower(), host, port if port is not None else _DEFAULT_PORTS.get(
        url.scheme.lower())


def _is_address(text: str) -> bool:
    try:
        ipaddress.ip_address(text)
    except ValueError:
        return False
    return True


def _pattern_matches(pattern: str, parts) -> bool:
    match = _PATTERN.match(pattern.strip().lower())
    if match is None:
        return False
    scheme, host, port = match['scheme'], match['host'], match['port']
    host = host.replace('[[]', '[')   # the escaped bracket of the earlier shell patterns
    if host.startswith('[') and host.endswith(']'):
        host = host[1:-1]
    got_scheme, got_host, got_port = parts
    if not (fnmatch.fnmatchcase(got_scheme, scheme) and fnmatch.fnmatchcase(got_host, host)):
        return False
    if port is None or port == '':
        return got_port == _DEFAULT_PORTS.get(got_scheme)
    return got_port is not None and fnmatch.fnmatchcase(str(got_port), port)


def origin_allowed(origin: str, allowed) -> bool:
    """Whether browser ``origin`` is one that ``allowed`` admits (see the module docstring)."""
    parts = _origin_parts(origin)
    for pattern in allowed:
        if pattern.strip() == '*':
            return True
        if '://' not in pattern:   # not a URL: 'null', matched whole
            if fnmatch.fnmatchcase(origin.strip().lower(), pattern.strip().lower()):
                return True
        elif parts is not None and _pattern_matches(pattern, parts):
            return True
    return False


def is_loopback(address: str) -> bool:
    """Whether ``address`` (an IP address a socket is bound to) is a loopback address."""
    try:
        return ipaddress.ip_address(address.split('%')[0]).is_loopback
    except ValueError:
        return False


def host_problem(host: str | None) -> str:
    """Return why the ``Host`` header ``host`` does not name loopback ('' when it does)."""
    if not host:
        return 'no Host header'
    try:
        url = urlsplit('//' + host.strip())
        url.port   # noqa: B018 - raises ValueError for a port that is no number
    except ValueError:
        return f'Host {host[:80]!r} is not host[:port]'
    name = (url.hostname or '').lower().rstrip('.')
    if url.path or url.query or url.fragment or url.username is not None or '@' in url.netloc:
        return f'Host {host[:80]!r} is not host[:port]'
    if name == 'localhost' or name.endswith('.localhost') or is_loopback(name):
        return ''
    return f'Host {host[:80]!r} does not name this machine\'s loopback ({LOOPBACK_HOSTS})'
