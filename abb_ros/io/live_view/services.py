"""The services a live view advertises: their request and response schemas (``ros2msg``).

The texts are the halves of the ``.srv`` files the message packages install, as the
protocol's ``advertiseServices`` carries them.
"""

from __future__ import annotations

import re

from abb_ros.io.live_view.protocol import ENCODING, SCHEMA_ENCODING
from abb_ros.io.wire import msgdefs

__all__ = ['service_info', 'service_texts']


def service_texts(type_name: str) -> tuple[str, str]:
    """Return the request and response ``ros2msg`` texts of service ``pkg/srv/Name``."""
    package, _, name = type_name.split('/')
    text = (msgdefs.share_dir(package) / 'srv' / f'{name}.srv').read_text()
    request, response = re.split(r'^---[ \t]*$', text, maxsplit=1, flags=re.M)
    return request.strip() + '\n', response.strip() + '\n'


def service_info(service_id: int, name: str, type_name: str) -> dict:
    """Return a service as ``advertiseServices`` lists it.

    With the ``request``/``response`` schemas, and the ``requestSchema``/``responseSchema``
    texts the protocol's first clients read.
    """
    request, response = service_texts(type_name)

    def schema(part: str, text: str) -> dict:
        return dict(encoding=ENCODING, schemaName=f'{type_name}_{part}',
                    schemaEncoding=SCHEMA_ENCODING, schema=text)

    return dict(id=service_id, name=name, type=type_name,
                request=schema('Request', request), response=schema('Response', response),
                requestSchema=request, responseSchema=response)
