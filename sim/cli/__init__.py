"""The ``k37`` command line (:func:`main`), one module per family of commands."""

from k37.sim.cli.main import build_parser, main

__all__ = ["build_parser", "main"]
