"""Plates are defined in ``proxyshade.plate`` (beside ``proxyshade.errors``), where the engine,
io and the synthesis layer all import them; this name is kept for existing imports."""
from proxyshade.plate import DTYPES, Plate, PlateError, check_channel_name  # noqa: F401
