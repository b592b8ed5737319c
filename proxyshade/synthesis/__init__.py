"""The synthesis layer: the operations the synthesis nodes share, as plain functions on
arrays and plates, between the nodes (``proxyshade.nodes``: declare inputs and
parameters, call this layer) and the numba kernels (``proxyshade.kernels``: hot loops).

Modules, one operation family each:

* ``params``    parameter groups declared once and inherited by the nodes that use them
* ``labels``    label tables, dense label maps, the guide at the synthesis size
* ``exemplar``  ``SynthesisSetup``: the exemplar, pyramid levels and coordinate conversions
* ``patches``   flood fill, k-coherent correction, magnification, label repair (§5)
* ``guide``     the guidance-synthesis pyramid (§4)
* ``blend``     Poisson seam blending, whole-frame or restricted (§5 step 3, §6.3)
* ``temporal``  reprojection of the synthesis state, flags, re-anchoring (§6.2)
* ``memo``      results kept for the arrays of one run (similarity sets, the frame-0 grid)

Layer functions raise ``proxyshade.errors.NodeInputError`` with a one-line message (what
is wrong and the fix); the engine prefixes the node's name and frame.
"""
