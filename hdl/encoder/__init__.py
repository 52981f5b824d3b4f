"""The quadrature encoder interface: the chip, its register map and reference model."""
