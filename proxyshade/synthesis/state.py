"""Names of the carried synthesis state (no kernels imported: node declarations and the
engine read them without loading numba).

``CATEGORY``: ConsistentDepth's pixel kinds; ``FLAG``: Reproject's reasons (0 kept, 1
disoccluded, 2 newly occluded, 3 distorted, 4 re-anchored); ``STATE``: the channels a
frame carries to the next; ``GEOMETRY``: this frame's, not carried; ``CORRECTION``: the
carried Poisson correction (colour minus the source through the map).
"""
CATEGORY = {"A": 1, "B": 2, "C": 3, "D": 4}  # ConsistentDepth's pixel kinds (see that node)
FLAG = {"none": 0, "disoccluded": 1, "newly_occluded": 2, "distorted": 3, "reanchored": 4}
CATEGORY_C = CATEGORY["C"]
STATE = ("R", "G", "B", "source.x", "source.y", "patch.id", "label.id")
GEOMETRY = ("label.id", "Z", "P.X", "P.Y", "P.Z", "N.X", "N.Y", "N.Z", "object.id")  # this frame's, not carried
CORRECTION = ("correction.R", "correction.G", "correction.B")  # colour minus the source through the map
