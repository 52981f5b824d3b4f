"""The one top-level package, ``k37``: the checkout's ``hdl/``, ``sim/`` and ``firmware_model/``
folders install as ``k37.hdl``, ``k37.sim`` and ``k37.firmware_model`` (everything else is in
``pyproject.toml``)."""

from setuptools import find_packages, setup

FOLDERS = ("hdl", "sim", "firmware_model")

setup(
    packages=[f"k37.{package}" for folder in FOLDERS
              for package in find_packages(include=[folder, f"{folder}.*"])],
    package_dir={f"k37.{folder}": folder for folder in FOLDERS},
)
