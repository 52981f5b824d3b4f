"""The KM3702 position controller: the chip, its register map and reference model."""
