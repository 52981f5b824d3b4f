"""K37's tests, in folders that mirror the packages (``hdl``, ``sim``, ``firmware_model``), with
the whole machine's in ``system``; the helpers they share are beside this file."""
