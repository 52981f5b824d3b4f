"""The reference model of the host bus's register banks in plain Python."""
