"""Synthesisable gateware of the K37 chipset, one hardware block per module.

A package's reference models are its module ``model`` or the modules of its subpackage
``model``, and its register maps likewise ``map`` or ``map/`` (``k3702/model.py``,
``feed/model/divider.py``, ``feed/map/feed_rate.py``), so that the globs ``k37.hdl.**.model``
and ``k37.hdl.**.map`` of the Amaranth-free import contract (``pyproject.toml``) match them all.
"""
