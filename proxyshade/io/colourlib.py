"""colour-science, imported on first use: its import takes about half a second (it pulls
in scipy and its plotting helpers), which a command that decodes or grades nothing (a
fully cached run, ``--help``) should not pay."""
from __future__ import annotations

import functools
import warnings


@functools.cache
def colour_science():
    """The ``colour`` module (colour-science)."""
    warnings.filterwarnings("ignore", message='.*"Matplotlib" related API features.*')
    import colour

    return colour
