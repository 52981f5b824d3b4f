"""The frame of a self-contained report page: plotly.js, the page's style and script, and its
data, all inside one HTML file (nothing is fetched when it opens).

Numeric arrays travel as base64 of their little-endian bytes (:func:`packed`), a quarter of
their decimal text; the page's script turns them back into typed arrays, which plotly.js
draws as they are.
"""

from __future__ import annotations

import base64
import html
import json
from functools import cache
from importlib import resources
from typing import Any

import numpy as np

__all__ = ["packed", "page"]

_HERE = resources.files(__package__)


def packed(values: Any, dtype: str = "<f4") -> dict[str, str]:
    """An array as the page's script reads it: ``{"b64": ..., "dtype": "f4" or "i4"}``
    (NaN and infinities stay as they are in float arrays)."""
    array = np.ascontiguousarray(np.asarray(values, dtype=dtype))
    return {"b64": base64.b64encode(array.tobytes()).decode("ascii"), "dtype": dtype[1:]}


@cache
def _asset(name: str) -> str:
    return (_HERE / name).read_text(encoding="utf-8")


@cache
def _plotly_js() -> str:
    from plotly.offline import get_plotlyjs

    return get_plotlyjs()


def _script(text: str) -> str:
    """A script's text, safe inside a ``<script>`` element."""
    return text.replace("</script", "<\\/script")


def page(title: str, body: str, data: dict[str, Any], script: str) -> str:
    """A whole page: ``body`` (HTML) under a heading ``title``, ``data`` (JSON-able, with
    :func:`packed` arrays) as ``window.K37``, then the shared script ``common.js`` and the
    page's script (a file of this package)."""
    payload = json.dumps(data, separators=(",", ":"), allow_nan=False).replace("<", "\\u003c")
    return "\n".join([
        "<!DOCTYPE html>", '<html lang="en">', "<head>", '<meta charset="utf-8">',
        '<meta name="viewport" content="width=device-width, initial-scale=1">',
        f"<title>{html.escape(title)}</title>",
        f"<style>{_asset('report.css')}</style>", "</head>", "<body>",
        f"<h1>{html.escape(title)}</h1>", body,
        f"<script>{_script(_plotly_js())}</script>",
        f'<script id="k37-data" type="application/json">{payload}</script>',
        f"<script>{_script(_asset('common.js'))}</script>",
        f"<script>{_script(_asset(script))}</script>",
        "</body>", "</html>", ""])
