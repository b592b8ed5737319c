"""The synthesis layer: the operations the synthesis nodes share, as plain functions on
arrays and plates, between the nodes (``proxyshade.nodes``: declare inputs and
parameters, call this layer) and the numba kernels (``proxyshade.kernels``: hot loops).

Methods: N. Bonneel, M. van de Panne, S. Lefebvre, G. Drettakis, "Proxy-Guided Texture
Synthesis for Rendering Natural Scenes", INRIA RR-7298, 2010 (§ numbers below are its);
E. Risser, C. Han, R. Dahyot, E. Grinspun, "Synthesizing Structured Image Hybrids",
SIGGRAPH 2010; O. Diamanti, C. Barnes, S. Paris, E. Shechtman, O. Sorkine-Hornung,
"Synthesis of Complex Image Appearance from Limited Exemplars", ACM TOG 34(2), 2015
(annotated exemplars); A. Neubeck, A. Zalesny, L. Van Gool, "Viewpoint Consistent Texture
Synthesis", 3DPVT 2004 (BTF synthesis).

Modules, one operation family each:

* ``params``       parameter groups declared once and inherited by the nodes that use them
* ``state``        names of the carried synthesis state (no kernels imported)
* ``labels``       label tables, dense label maps, the guide at the synthesis size
* ``exemplar``     ``SynthesisSetup``: the exemplar, pyramid levels and coordinate conversions
* ``patches``      flood fill, k-coherent correction, magnification, label repair (§5)
* ``guide``        the guidance-synthesis pyramid (§4)
* ``depth``        depth extension to the detailed guide's borders by jump flooding (§4.3, §7)
* ``blend``        Poisson seam blending, whole-frame or restricted (§5 step 3, §6.3)
* ``grain``        the photo's detail, scale by scale and label by label (a Poisson option)
* ``temporal``     reprojection of the synthesis state, flags, re-anchoring (§6.2)
* ``resynthesis``  the first frame's steps restricted to flagged pixels (§6.3)
* ``edit``         the changed region of a progressive update after an edit (§7)
* ``edit_colour``  the colour synthesis of a progressive edit (§7)
* ``relight``      a synthesized frame relit from another photo of the same view (§8)
* ``annotated``    annotated-exemplar synthesis (Diamanti et al. 2015)
* ``hybrid``       structured image hybrids (Risser et al. 2010)
* ``btf``          BTF stacks: capture, alignment, view-consistent synthesis (Neubeck et al.)
* ``memo``         results kept for the arrays of one run (similarity sets, the frame-0 grid)
* ``tiles``        row bands of the correction on other workers (Dask): the tile runner's contract

Layer functions raise ``proxyshade.errors.NodeInputError`` with a one-line message (what
is wrong and the fix); the engine prefixes the node's name and frame.
"""
