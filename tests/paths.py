"""Paths the tests share: :data:`ROOT`, the checkout's root."""

from pathlib import Path

#: The checkout's root (the folder holding ``pyproject.toml``).
ROOT = Path(__file__).resolve().parents[1]
