# amaranth: UnusedElaboratable=no
"""What the compiled backend's tests share: the test designs (:mod:`tests.sim.backends.designs`)
on Amaranth's simulator and on CXXRTL, built once per module (the models are cached)."""

import pytest

from k37.sim.backends.cxxrtl.backend import CxxrtlBackend
from k37.sim.backends.pysim import PysimBackend
from tests.sim.backends.designs import BLOCKS, Zoo


def zoo_pair(blocks: tuple[str, ...]):
    """Both backends on a Zoo of ``blocks``, closed afterwards (for module fixtures)."""
    pysim, cxxrtl = PysimBackend(Zoo(blocks)), CxxrtlBackend(Zoo(blocks))
    yield pysim, cxxrtl
    pysim.close()
    cxxrtl.close()


@pytest.fixture(scope="module")
def backends():
    """The Zoo on Amaranth's simulator and on CXXRTL (built once per machine, then cached)."""
    yield from zoo_pair(tuple(BLOCKS))


@pytest.fixture
def pair(backends):
    for backend in backends:
        backend.reset()
    return backends


#: Without the negedge counter, nothing happens on the falling edge (the backend skips it);
#: without the bit chain, one evaluation settles an edge (combinational outputs then lag the
#: state until the backend settles them for a read).
SIMPLE = tuple(name for name in BLOCKS if name not in ("negc", "chain"))


@pytest.fixture(scope="module")
def simple():
    """A second Zoo, on CXXRTL's fast paths."""
    yield from zoo_pair(SIMPLE)


#: With falling-edge logic but without the bit chain's feedback: a wait on a combinational
#: output reads it after the next falling edge's evaluation, and undoes that edge if it is set.
PEEKING = tuple(name for name in BLOCKS if name != "chain")


@pytest.fixture(scope="module")
def peeking():
    """A third Zoo, on CXXRTL's fast path for waits (k37.sim.backends.cxxrtl.evals.edge_wires)."""
    yield from zoo_pair(PEEKING)


@pytest.fixture(params=["backends", "simple"])
def pair_or_simple(request):
    """Each Zoo in turn, reset."""
    backends = request.getfixturevalue(request.param)
    for backend in backends:
        backend.reset()
    return backends
