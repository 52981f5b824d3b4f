"""The compiled backend: CXXRTL C++ built with g++ (``build.py``), driven through ctypes
(``backend.py``) and a C harness (``harness.cc`` and the parts it includes) that steps,
records and skips idle cycles."""
