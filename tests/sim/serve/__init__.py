"""Tests of ``k37 serve`` and the host link's transports."""
