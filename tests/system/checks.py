"""Checks the fault tests share: one error line, and a child process that imports the checkout."""

from __future__ import annotations

import os

from tests.paths import ROOT

#: The environment of a child ``python`` that runs the command line from this checkout.
ENV = {**os.environ, "PYTHONPATH": str(ROOT)}


def one_error(err: str, *parts: str) -> None:
    assert err.count("\n") == 1 and err.startswith("k37: error: "), err
    assert "Traceback" not in err
    for part in parts:
        assert part in err, err
